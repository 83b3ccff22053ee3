#!/usr/bin/env bash
# A dataset as a Slurm job array: one shard per array task, all writing to one folder on
# shared storage. Each task reads its shard from SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT;
# a task that is preempted or requeued reruns its shard and skips the episodes it finished.
#   sbatch --array=0-31%8 launch-scripts/dataset_slurm.sh /shared/grasp-dataset 10000
#SBATCH --job-name=dvrk-dataset
#SBATCH --cpus-per-task=8
#SBATCH --time=24:00:00
#SBATCH --requeue
set -euo pipefail
OUT=${1:?usage: sbatch --array=0-N launch-scripts/dataset_slurm.sh OUT_DIR EPISODES [SCENE] [VARY]}
EPISODES=${2:?number of episodes in the whole dataset}
SCENE=${3:-config/default.toml}
VARY=${4:-config/vary/grasp.toml}
# Run from the checkout (the scene and variation paths are relative to it).
cd "${SLURM_SUBMIT_DIR:-$(dirname "$0")/..}"
BIN=${DVRK_TISSUE_SIM:-target/release/dvrk-tissue-sim}
# Two episodes at a time, each on half the task's cores; on a GPU partition give each task
# --gres=gpu:1 and run one episode at a time with --backend gpu.
exec "$BIN" dataset --scene "$SCENE" --vary "$VARY" --episodes "$EPISODES" --out "$OUT" \
    --seed "${SEED:-0}" --jobs "${JOBS:-2}"
