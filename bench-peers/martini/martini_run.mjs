// @mapbox/martini 0.2.0 on a raw f32 (2^k+1)^2 grid: createTile and getMesh times (best of REPS),
// the mesh's measured vertical error (full grid scan, f64), and the equal-measured-error point:
// the largest E' <= E whose measured error is still <= E (bisection, 30 steps).
// usage: node martini_run.mjs RAW N REPS E...   prints one JSON line per E.
import fs from 'fs';
import Martini from '@mapbox/martini';

const [raw, nStr, repsStr, ...es] = process.argv.slice(2);
const n = +nStr, reps = +repsStr;
const buf = fs.readFileSync(raw);
const terrain = new Float32Array(buf.buffer, buf.byteOffset, n * n);

function best(f) {
    let t = Infinity, r;
    for (let i = 0; i < reps; i++) {
        const s = process.hrtime.bigint();
        r = f();
        t = Math.min(t, Number(process.hrtime.bigint() - s) / 1e6);
    }
    return [t, r];
}

// max |h - mesh| over every sample of every triangle (closed), barycentric in f64.
function measured(mesh) {
    const v = mesh.vertices, t = mesh.triangles;
    let max = 0;
    for (let k = 0; k < t.length; k += 3) {
        const ax = v[2 * t[k]], ay = v[2 * t[k] + 1];
        const bx = v[2 * t[k + 1]], by = v[2 * t[k + 1] + 1];
        const cx = v[2 * t[k + 2]], cy = v[2 * t[k + 2] + 1];
        const az = terrain[ay * n + ax], bz = terrain[by * n + bx], cz = terrain[cy * n + cx];
        const det = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay);
        if (det === 0) continue;
        const x0 = Math.min(ax, bx, cx), x1 = Math.max(ax, bx, cx);
        const y0 = Math.min(ay, by, cy), y1 = Math.max(ay, by, cy);
        for (let y = y0; y <= y1; y++) {
            for (let x = x0; x <= x1; x++) {
                const l1 = ((x - ax) * (cy - ay) - (cx - ax) * (y - ay)) / det;
                const l2 = ((bx - ax) * (y - ay) - (x - ax) * (by - ay)) / det;
                const l0 = 1 - l1 - l2;
                if (l0 < -1e-12 || l1 < -1e-12 || l2 < -1e-12) continue;
                const z = l0 * az + l1 * bz + l2 * cz;
                const d = Math.abs(terrain[y * n + x] - z);
                if (d > max) max = d;
            }
        }
    }
    return max;
}

const martini = new Martini(n);
const [createMs, tile] = best(() => martini.createTile(terrain));
for (const eStr of es) {
    const e = +eStr;
    const [meshMs, mesh] = best(() => tile.getMesh(e));
    const err = measured(mesh);
    // Equal measured error: bisection on E' in [0, E].
    let lo = 0, hi = e, loMesh = tile.getMesh(0);
    if (err <= e) { lo = e; loMesh = mesh; }
    else {
        for (let i = 0; i < 30; i++) {
            const mid = (lo + hi) / 2;
            const m = tile.getMesh(mid);
            if (measured(m) <= e) { lo = mid; loMesh = m; } else { hi = mid; }
        }
    }
    const [eqMs] = best(() => tile.getMesh(lo));
    console.log(JSON.stringify({
        tool: 'martini', n, E: e, create_ms: createMs, mesh_ms: meshMs,
        triangles: mesh.triangles.length / 3, vertices: mesh.vertices.length / 2, measured: err,
        E_equal: lo, triangles_equal: loMesh.triangles.length / 3, measured_equal: measured(loMesh),
        mesh_ms_equal: eqMs,
    }));
}
