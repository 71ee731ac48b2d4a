#!/usr/bin/env bash
# Clarabel's default QDLDL against its `faer-sparse` LDL on the SO(3) entropy
# LP at q = 2000. The comparison lives in its own cargo project
# (scripts/faer_ldl, own [workspace] and target dir) so that the workspace's
# Clarabel build, and every other build, stays without `faer-sparse`.
#
# Usage: scripts/faer_ldl.sh [REPEATS]
set -euo pipefail
cd "$(dirname "$0")/.."

LP=target/bench-data/entropy_lp_rigid_body_q2000.json
if [[ ! -f "$LP" ]]; then
    echo "writing $LP with the identification bench (sections 3-5 only)"
    cargo bench --bench identification -- --quick --solver-only >/dev/null
fi
(cd scripts/faer_ldl && cargo build --release --target-dir ../../wip/faer-target)
wip/faer-target/release/faer_ldl "$LP" "${1:-3}"
