#!/usr/bin/env bash
# The scene figures of docs/experiments/scene: `forte plan` (method forte) of each scene example
# writes scene.png into its plan directory; this copies it here, named after the task.
# Run from the repository root: bash docs/experiments/scene/make_figures.sh
set -euo pipefail
for task in around-the-crate table-to-shelf through-the-doorway; do
    forte plan "examples/tasks/$task.yaml" --out "runs/scene/$task" --quiet
    cp "runs/scene/$task/scene.png" "docs/experiments/scene/$task.png"
done
