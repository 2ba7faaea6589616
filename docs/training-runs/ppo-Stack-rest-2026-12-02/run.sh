#!/bin/sh
# The runs of this record, from the repository's root: `run.sh [NAME [--resume]]` trains
# ../ppo-Stack-tight-2026-12-02/recipe-first.yml into runs/ppo-Stack-first (unless that run is
# there already), then recipe-NAME.yml (`rest` unless given) into runs/ppo-Stack-NAME from the
# first part's last checkpoint (with `--resume`, goes on from runs/ppo-Stack-NAME's own), keeping
# every checkpoint as runs/ppo-Stack-NAME/ckpt-STEPS.zip: that record's run.sh with this
# directory's recipes. As run: `run.sh` (stopped by hand after 5 M steps), then `run.sh bound`.
d=$(dirname "$0")
SECOND_RECIPES=$d exec "$d/../ppo-Stack-tight-2026-12-02/run.sh" "${1:-rest}" ${2:+"$2"}
