#!/usr/bin/env bash
# Train several configs side by side, one core each, for a fixed wall-clock budget, then
# pack their validation CSVs, TensorBoard logs and logs into one archive.
#   bash research/offpolicy/exploration/probe.sh SECONDS ARCHIVE CONFIG:SEED [CONFIG:SEED ...]
# (PYTHON names the interpreter, python by default.)
# Each run is stopped with SIGTERM at SECONDS (train.py then saves a checkpoint); what it
# validated until then is in its evaluations.csv. Runs go to runs/probe/NAME_sSEED.
set -u
budget=$1 archive=$2; shift 2
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 PYTHONUNBUFFERED=1
# compile (and cache) the env's kernels once, so that the runs do not all compile at once
"${PYTHON:-python}" -c "import gymnasium as gym, hoprover_env; e = gym.make('HopRoverRL-v1'); e.reset(seed=0); e.step(e.action_space.sample())"
mkdir -p runs/probe
start=$(date +%s)
for spec in "$@"; do
    cfg=${spec%%:*} seed=${spec##*:} name=$(basename "${spec%%:*}" .yaml)_s${spec##*:}
    timeout -s TERM -k 60 $((budget - ($(date +%s) - start))) \
        "${PYTHON:-python}" train.py --config "$cfg" --out "runs/probe/$name" --seed "$seed" \
        --torch-threads 1 --no-progress > "runs/probe/$name.log" 2>&1 &
done
wait
tar czf "$archive" --exclude='*.zip' --exclude='*.pkl' --exclude='checkpoints' -C runs probe
echo "packed $(tar tzf "$archive" | wc -l) files after $(( $(date +%s) - start )) s"
