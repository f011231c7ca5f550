#!/usr/bin/env bash
# The main job: every built-in scene with its defaults, one summary line each.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
nonholo_build nonholo_cli
for scene in particle sleigh sleigh_contact snakeboard sleigh_chain wheeled_train; do
  "$NONHOLO_BUILD/nonholo" run "$scene"
done
