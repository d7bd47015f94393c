# shellcheck shell=bash
# Sourced by the TIN peer scripts (tin_peers.sh, tin_robust_ab.sh): strict mode, the folders
# they work in and pydelatin 0.4.0 (PyPI) installed into bench-peers/.venv. Sets `here` (this
# folder, also the working directory), `root` (the repository), DATA and ROUNDS (defaults
# ../shared/data and 3).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(dirname "$here")
DATA=${DATA:-$root/../shared/data}
ROUNDS=${ROUNDS:-3}
cd "$here"
if [ ! -x .venv/bin/python ]; then python3 -m venv .venv; fi
.venv/bin/python -c "import pydelatin, numpy, PIL" 2>/dev/null ||
    .venv/bin/pip install -q "pydelatin==0.4.0" numpy pillow
