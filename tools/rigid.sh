#!/usr/bin/env bash
# The 3-D example of docs/guide/rigid-bodies.md: a Chaplygin ball, a rolling disk and the Suslov top
# (with the defaults and with the plain method) to HDF5 in ./out/rigid, their summaries, and a
# picture of them in out/rigid_bodies.png (tools/plot_rigid.py).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
nonholo_require python3-matplotlib python3-h5py
nonholo_build nonholo_cli
dir="$NONHOLO_ROOT/out/rigid"
mkdir -p "$dir"
cli="$NONHOLO_BUILD/nonholo"
"$cli" run chaplygin_ball --t-end 60 --every 5 --out "$dir/ball.h5"
"$cli" run rolling_disk --t-end 8 --every 4 --out "$dir/disk.h5"
"$cli" run suslov --t-end 200 --every 10 --out "$dir/suslov.h5"
"$cli" run suslov --t-end 200 --every 10 --restart 0 --out "$dir/suslov_plain.h5" || true  # warns: the mode
/usr/bin/python3 "$NONHOLO_ROOT/tools/plot_rigid.py" "$dir" "$NONHOLO_ROOT/out/rigid_bodies.png"
echo "picture: $NONHOLO_ROOT/out/rigid_bodies.png" >&2
