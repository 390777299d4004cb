#!/usr/bin/env bash
# CCNet at the paper's width and batch on one lent GPU, as one device call (docs/gpu.md).
#
# Needs the compact dataset copy in cache/pack (python -m data_prep pack-ccnet) and the roma
# wheel in .whl/ (the GPU image lacks it). Trains the configs in $CONFIGS at the same time,
# each for $MIN minutes of its own (the trainer sets its steps from the measured step time),
# then writes under $OUT: each best-by-validation model split into files under 16 MiB, and
# runs.tgz (logs, loss curves, the one-step table on the held-out clips).
# Dry run on a CPU: DEVICE=cpu MIN=0.3 BATCH=4 SIZE=quick OUT=cache/gpu_dry tools/gpu_train.sh
set -uo pipefail
export PYTHONUNBUFFERED=1
n=$(python3 -c "import numpy as np; print(int(np.load('cache/pack/ccnet.npz')['chunks']))" 2>/dev/null) || n=0
[ "$n" -gt 0 ] || { echo "missing cache/pack/ccnet.npz: carry cache/pack (python -m data_prep pack-ccnet)"; exit 1; }
for k in $(seq 0 $((n - 1))); do
    [ -f "cache/pack/motions-$k.npz" ] || { echo "missing cache/pack/motions-$k.npz (one device call carries each chunk)"; exit 1; }
done
MIN=${MIN:-6}
CONFIGS=${CONFIGS:-"paper_gpu paper_gpu_residual"}
OUT=${OUT:-cache/gpu_out}
RUNS=${RUNS:-/tmp/mocapviz_runs}
EXTRA=()
[ -n "${DEVICE:-}" ] && EXTRA+=(--device "$DEVICE")
[ -n "${BATCH:-}" ] && EXTRA+=(--batch-size "$BATCH")
[ -n "${SIZE:-}" ] && EXTRA+=(--size "$SIZE" --eval-every 1000000)
if ! python3 -c "import roma" 2>/dev/null; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl || exit 1
    export PYTHONPATH=/tmp/site
fi
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,memory.total,clocks.sm --format=csv,noheader
mkdir -p "$RUNS" "$OUT"
t0=$(date +%s)
# once, for every run: the features rebuilt and checked, saved as cache/pack/unpacked.npz
python3 -c "from data_prep.pack import unpack; unpack('cache/pack', workers=$(nproc), cache=True)" || exit 1
for cfg in $CONFIGS; do
    python3 -m data_prep train --config "$cfg" --packed cache/pack --out "$RUNS/$cfg" --minutes "$MIN" \
        --no-resume "${EXTRA[@]}" > "$RUNS/$cfg.log" 2>&1 &
done
wait
echo "training: $(( $(date +%s) - t0 )) s"
models=()
for cfg in $CONFIGS; do
    tail -c 600 "$RUNS/$cfg.log" | tr '\r' '\n' | tail -4
    if [ -f "$RUNS/$cfg/best.safetensors" ] && [ -f "$RUNS/$cfg/checkpoint.safetensors" ]; then
        models+=(--model "$RUNS/$cfg/best.safetensors")
        # float16 (18 MB for the paper's width), in files under 16 MiB: every model comes back
        python3 -c "from mocapviz.training.runs import export_model as e; e('$RUNS/$cfg', '$RUNS/$cfg/half.safetensors', half=True)"
        python3 -c "from mocapviz.training.checkpoint import split_checkpoint as s; s('$RUNS/$cfg/half.safetensors', '$OUT/$cfg.safetensors', 15 * 2**20)"
    fi
done
[ ${#models[@]} -gt 0 ] && python3 -m data_prep one-step --packed cache/pack "${models[@]}" --csv "$RUNS/one_step.csv"
tar czf "$OUT/runs.tgz" -C "$RUNS" --exclude='*.safetensors' .
ls -la "$OUT"
echo "total: $(( $(date +%s) - t0 )) s"
