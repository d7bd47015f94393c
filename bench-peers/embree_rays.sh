#!/bin/sh
# Embree (embreex) against `relief trace` on every DEM in ../shared/data and the bundled one:
# pixel agreement of the triangles surface (1e-4 relative) and single-thread rays per second,
# camera and grazing views. One JSON line per DEM, view and method.
#
# usage (from the repository root): bench-peers/embree_rays.sh RELIEF_BIN [ROUNDS] [WxH]
# ONLY="puget fuji" limits the run to those DEMs (names in the list at the end); METHODS (default
# "maxmip maxmip-scalar run-dda"; also maxmip-wide: AVX-512F, AVX2 or portable) to those methods; VIEWS (default
# "camera grazing"; also low, a level view from just above the ground) to those views.
# CHUNK_ROUNDS (default 2) sets how many alternating chunked rounds embree_trace.py times;
# IR=1 adds instructions per ray of both (valgrind: cachegrind for relief, callgrind inside
# rtcIntersect1 for Embree; see embree_trace.py).
# needs: python3 -m venv /tmp/venv-embree && /tmp/venv-embree/bin/pip install
#        embreex==4.4.0.post1 numpy pillow    (or set PY to a python that has them)
set -eu
RELIEF=$1
ROUNDS=${2:-5}
SIZE=${3:-384x256}
PY=${PY:-/tmp/venv-embree/bin/python}
DATA=../shared/data
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
# name file format dx dy z-multiplier (spacings from ../shared/data/README.md)
while read -r name file fmt dx dy zmul; do
    case " ${ONLY:-$name} " in *" $name "*) ;; *) continue ;; esac
    dims=$("$PY" bench-peers/dem_to_raw.py "$file" "$fmt" "$TMP/$name.raw")
    w=${dims% *}
    h=${dims#* }
    "$PY" -c "import numpy as n,sys; a=n.fromfile(sys.argv[1],'<f4')*n.float32($zmul); a.astype('<f4').tofile(sys.argv[1])" "$TMP/$name.raw"
    for view in ${VIEWS:-camera grazing}; do
        for method in ${METHODS:-maxmip maxmip-scalar run-dda}; do
            "$PY" bench-peers/embree_trace.py "$RELIEF" "$TMP/$name.raw" "$w" "$h" "$dx" "$dy" \
                "$view" "$SIZE" "$method" "$ROUNDS"
            echo
        done
    done
done <<LIST
puget data/puget_sound_1k.png png 160 160 0.1
fuji $DATA/martini_fuji.png terrain-rgb 62.4 62.4 1
bayhills $DATA/delatin_14-2625-6369.png terrain-rgb 3.81 3.81 1
sthelens $DATA/pymartini_mapbox_st_helens.png terrain-rgb 6.61 6.61 1
canyon $DATA/pymartini_terrarium.png terrarium 61.8 61.8 1
tujunga $DATA/topotoolbox_srtm_bigtujunga30m_utm11.tif tiff 30 30 1
pysheds $DATA/pysheds_dem.tif tiff 77.9 92.6 1
LIST
