#!/usr/bin/env bash
# The main job: a generated wheeled_train (1000 bodies by default; pass --set bodies=N and
# other `nonholo run` options to change it) with its trajectory CSV, a PNG of the train and its
# path, and a GIF following the train's front (nonholo animate, 100 frames) in ./out, and its
# summary line. Builds the command-line tool and the Python package
# (build/python), so that README's next steps work.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
nonholo_require python3-matplotlib python3-pil
nonholo_build nonholo_cli nonholo_python
mkdir -p "$NONHOLO_ROOT/out"
csv="$NONHOLO_ROOT/out/wheeled_train.csv"
png="$NONHOLO_ROOT/out/wheeled_train.png"
gif="$NONHOLO_ROOT/out/wheeled_train.gif"
"$NONHOLO_BUILD/nonholo" run wheeled_train --every 20 --out "$csv" "$@"
/usr/bin/python3 "$NONHOLO_ROOT/tools/plot_train.py" "$csv" "$png"
"$NONHOLO_BUILD/nonholo" animate "$csv" -o "$gif" --follow --frames 100 --width 560 --fps 15 --trail 8
echo "trajectory: $csv" >&2
echo "picture:    $png" >&2
echo "animation:  $gif" >&2
echo "python:     PYTHONPATH=$NONHOLO_BUILD/python /usr/bin/python3 -c 'import nonholo'" >&2
