#!/usr/bin/env bash
# How closely `relief render --backend cpu` reproduces the GPU frame's colours: the share of
# pixels whose RGB agree to 3 of 255 in every channel, for four effect sets on the bundled DEM
# (the camera of cli/tests/render.rs, 160 x 120).
#
#   bash adapters/wgpu/bench/lit_backends.sh [RELIEF_CPU] [RELIEF_GPU]
#
# RELIEF_CPU renders the CPU frames, RELIEF_GPU the GPU ones (both default to
# target/release/relief), so a CPU backend built from another commit can be compared with the
# same GPU frames. Needs python3 (standard library only) and a GPU adapter (lavapipe will do).
set -euo pipefail
CPU="${1:-target/release/relief}"
GPU="${2:-target/release/relief}"
DIR=$(mktemp -d)
trap 'rm -rf "$DIR"' EXIT
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
args=(render --dem data/puget_sound_1k.png --dx 160 --dy 160 --z-scale 0.1
  --eye 20000,10000,6000 --target 90000,90000,500 --size 160x120)
for fx in lighting lighting,detail lighting,deformations lighting,shadows,fog,water; do
  "$CPU" "${args[@]}" --effects "$fx" --backend cpu --out "$DIR/cpu.png" >/dev/null
  "$GPU" "${args[@]}" --effects "$fx" --out "$DIR/gpu.png" >/dev/null
  printf '%-28s ' "$fx"
  python3 - "$DIR/cpu.png" "$DIR/gpu.png" <<'EOF'
import struct, sys, zlib

def rgba(path):
    """The pixels of an 8-bit RGBA PNG (relief's writer), filters undone."""
    d = open(path, 'rb').read()
    i, idat, w, h = 8, b'', 0, 0
    while i < len(d):
        n = struct.unpack('>I', d[i:i + 4])[0]
        t, c = d[i + 4:i + 8], d[i + 8:i + 8 + n]
        if t == b'IHDR':
            w, h = struct.unpack('>II', c[:8])
            assert c[8] == 8 and c[9] == 6, 'expected 8-bit RGBA'
        elif t == b'IDAT':
            idat += c
        i += 12 + n
    raw, stride, out, prev, p = zlib.decompress(idat), 4 * w, [], bytearray(4 * w), 0
    for _ in range(h):
        f, line = raw[p], bytearray(raw[p + 1:p + 1 + stride])
        p += 1 + stride
        for x in range(stride):
            a = line[x - 4] if x >= 4 else 0
            b = prev[x]
            c = prev[x - 4] if x >= 4 else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                q = a + b - c
                pa, pb, pc = abs(q - a), abs(q - b), abs(q - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        out.append(bytes(line))
        prev = line
    return b''.join(out)

a, b = rgba(sys.argv[1]), rgba(sys.argv[2])
n = len(a) // 4
close = sum(all(abs(a[4 * i + k] - b[4 * i + k]) <= 3 for k in range(3)) for i in range(n))
print(f'{close} of {n} pixels within 3 levels ({100 * close / n:.1f} %)')
EOF
done
