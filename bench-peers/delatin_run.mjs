// Run JS delatin (mapbox/delatin, npm delatin@0.2.0) on a raw f32 DEM at several max errors.
// usage: node delatin_run.mjs RAW.f32 WIDTH HEIGHT REPEATS E [E ...]
// prints one JSON object per E: tool, max_error, vertices, triangles, error (delatin's own),
// ms (best of REPEATS runs of construction + run(E)) and cpu_ms (the same runs' process CPU time,
// process.cpuUsage: user + system of every thread, so V8's helper threads, garbage collection
// included, count too).
import { readFileSync } from 'node:fs';
import Delatin from 'delatin';

const [path, w, h, reps, ...es] = process.argv.slice(2);
const width = Number(w);
const height = Number(h);
const buf = readFileSync(path);
const data = new Float32Array(buf.buffer, buf.byteOffset, width * height);

for (const e of es.map(Number)) {
    let best = Infinity;
    let bestCpu = Infinity;
    let tin = null;
    for (let i = 0; i < Number(reps); i++) {
        const c0 = process.cpuUsage();
        const t0 = process.hrtime.bigint();
        tin = new Delatin(data, width, height);
        tin.run(e);
        best = Math.min(best, Number(process.hrtime.bigint() - t0) / 1e6);
        const c = process.cpuUsage(c0);
        bestCpu = Math.min(bestCpu, (c.user + c.system) / 1e3);
    }
    console.log(JSON.stringify({
        tool: 'delatin-js',
        max_error: e,
        vertices: tin.coords.length / 2,
        triangles: tin.triangles.length / 3,
        error: tin.getMaxError(),
        ms: best,
        cpu_ms: bestCpu,
    }));
}
