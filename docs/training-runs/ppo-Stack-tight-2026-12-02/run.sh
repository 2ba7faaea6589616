#!/bin/sh
# The runs of this record, from the repository's root: `run.sh [SECOND [--resume]]` trains
# recipe-first.yml into runs/ppo-Stack-first (unless that run is there already), then
# recipe-SECOND.yml (`second` unless given) into runs/ppo-Stack-SECOND started from the first part's
# last checkpoint (`--init-from`; with `--resume`, goes on with runs/ppo-Stack-SECOND from its
# checkpoint instead), with the night record's run.sh (logs: runs/ppo-Stack-NAME.log). While they
# run it keeps every checkpoint as runs/ppo-Stack-NAME/ckpt-STEPS.zip, which the night record's
# milestones.py and this record's release.py measure. PKG: a directory holding the package of this
# tree (with its native module) for PYTHONPATH, if .venv's is not. As run: `run.sh` (its second part
# stopped by hand after 3 M steps), `run.sh still` (stopped by hand after 8 M), then `run.sh second
# --resume` (stopped by hand after 13 M). SECOND_RECIPES: the directory of recipe-SECOND.yml
# (this one's unless set; a later record's run.sh sets it). Options after `--resume` go to
# `panda-rapier train` (`--timesteps N`: on to N steps past the recipe's); with `--resume` the
# first part is not needed and not run.
set -e
d=$(dirname "$0")
second=${1:-second}
start="--init-from runs/ppo-Stack-first/checkpoints/latest.zip"
if [ "${2:-}" = --resume ]; then
    start=--resume
fi
# RESUME_FROM: a directory holding a run's last checkpoint (latest.zip, state.json, run.json,
# evaluations.jsonl) that `--resume` starts from where runs/ppo-Stack-SECOND is absent.
if [ "$start" = --resume ] && [ -n "${RESUME_FROM:-}" ] && [ ! -d "runs/ppo-Stack-$second" ]; then
    mkdir -p "runs/ppo-Stack-$second/checkpoints"
    cp "$RESUME_FROM/run.json" "$RESUME_FROM/evaluations.jsonl" "runs/ppo-Stack-$second/"
    cp "$RESUME_FROM/latest.zip" "$RESUME_FROM/state.json" "runs/ppo-Stack-$second/checkpoints/"
fi
if [ $# -gt 2 ]; then
    shift 2
else
    set --
fi
steps() { sed 's/.*"num_timesteps": *\([0-9]*\).*/\1/' "$1"; }
keep() {
    while sleep 15; do
        for name in first "$second"; do
            state=runs/ppo-Stack-$name/checkpoints/state.json
            [ -f "$state" ] || continue
            n=$(steps "$state")
            kept=runs/ppo-Stack-$name/ckpt-$n.zip
            [ -f "$kept" ] && continue
            cp "runs/ppo-Stack-$name/checkpoints/latest.zip" "$kept.part"
            # Kept only if whole and still the state's (a checkpoint being written is not).
            if python3 -m zipfile -t "$kept.part" >/dev/null 2>&1 && [ "$(steps "$state")" = "$n" ]; then
                mv "$kept.part" "$kept"
            else
                rm -f "$kept.part"
            fi
        done
    done
}
keep &
keeper=$!
trap 'kill $keeper' EXIT
export RECIPES=$d
if [ "$start" != --resume ] && [ ! -f runs/ppo-Stack-first/model.zip ]; then
    "$d/../ppo-Stack-stage-2026-12-01/run.sh" first
fi
RECIPES=${SECOND_RECIPES:-$d} "$d/../ppo-Stack-stage-2026-12-01/run.sh" "$second" $start "$@"
sleep 20
