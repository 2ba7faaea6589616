#!/bin/sh
# The run of this record, from the repository's root: `run.sh` trains
# ../ppo-Stack-tight-2026-12-02/recipe-first.yml into runs/ppo-Stack-first (unless that run is
# there already), then recipe-letgo.yml into runs/ppo-Stack-letgo from the first part's last
# checkpoint, keeping every checkpoint as runs/ppo-Stack-letgo/ckpt-STEPS.zip: that record's
# run.sh with this directory's recipe. `run.sh --resume --timesteps N` goes on to N steps from
# runs/ppo-Stack-letgo's own checkpoint or, where there is no such run, from this record's
# (resume/: the run's last checkpoint, its state, run.json and evaluations; not best.zip, so
# such a run's model.zip holds its last weights, whatever the CLI's last line says). As run: `run.sh`
# (20,000,768 steps), then twice the train command that `run.sh --resume --timesteps N` runs,
# with N 26000000 and 32000000 (32,002,048 steps). recipe-floor.yml (the gripper's exploration
# floor at 0.6, 5 M steps from resume/) ran as
# `RECIPES=$d ../ppo-Stack-stage-2026-12-01/run.sh floor --init-from $d/resume/latest.zip`.
set -e
d=$(dirname "$0")
RESUME_FROM=$d/resume SECOND_RECIPES=$d exec "$d/../ppo-Stack-tight-2026-12-02/run.sh" letgo "$@"
