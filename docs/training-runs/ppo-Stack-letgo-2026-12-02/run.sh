#!/bin/sh
# The run of this record, from the repository's root: `run.sh [--resume]` trains
# ../ppo-Stack-tight-2026-12-02/recipe-first.yml into runs/ppo-Stack-first (unless that run is
# there already), then recipe-letgo.yml into runs/ppo-Stack-letgo from the first part's last
# checkpoint (with `--resume`, goes on from runs/ppo-Stack-letgo's own), keeping every
# checkpoint as runs/ppo-Stack-letgo/ckpt-STEPS.zip: that record's run.sh with this directory's
# recipe.
d=$(dirname "$0")
SECOND_RECIPES=$d exec "$d/../ppo-Stack-tight-2026-12-02/run.sh" letgo ${1:+"$1"}
