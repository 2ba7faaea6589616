#!/bin/sh
# The runs of this record, from the repository's root. `run.sh [--resume [--timesteps N]]`:
# from scratch, the tight record's recipe-first.yml into runs/ppo-Stack-first (unless that run
# is there already), then recipe-release.yml into runs/ppo-Stack-release from the first part's
# last checkpoint (the tight record's run.sh, which keeps every checkpoint as
# runs/ppo-Stack-NAME/ckpt-STEPS.zip; `--resume` goes on from runs/ppo-Stack-release's own
# checkpoint or, where there is no such run, from this record's resume/: the run's last
# checkpoint, its state, run.json and evaluations, so that a later session goes on without
# the steps before). `run.sh finetune[10]`: recipe-finetune[10].yml into runs/ppo-Stack-finetune[10]
# from the let-go record's 32 M-step checkpoint (its resume/latest.zip), keeping its
# checkpoints the same way.
set -e
d=$(dirname "$0")
case "${1:-}" in
    finetune*) name=$1 ;;
    *)
        RESUME_FROM=$d/resume SECOND_RECIPES=$d exec \
            "$d/../ppo-Stack-tight-2026-12-02/run.sh" release "$@"
        ;;
esac
out=runs/ppo-Stack-$name
steps() { sed 's/.*"num_timesteps": *\([0-9]*\).*/\1/' "$1"; }
keep() {
    while sleep 15; do
        [ -f "$out/checkpoints/state.json" ] || continue
        n=$(steps "$out/checkpoints/state.json")
        [ -f "$out/ckpt-$n.zip" ] && continue
        cp "$out/checkpoints/latest.zip" "$out/ckpt-$n.zip.part"
        # Kept only if whole and still the state's (a checkpoint being written is not).
        if python3 -m zipfile -t "$out/ckpt-$n.zip.part" >/dev/null 2>&1 &&
            [ "$(steps "$out/checkpoints/state.json")" = "$n" ]; then
            mv "$out/ckpt-$n.zip.part" "$out/ckpt-$n.zip"
        else
            rm -f "$out/ckpt-$n.zip.part"
        fi
    done
}
keep &
keeper=$!
trap 'kill $keeper' EXIT
RECIPES=$d "$d/../ppo-Stack-stage-2026-12-01/run.sh" "$name" \
    --init-from "$d/../ppo-Stack-letgo-2026-12-02/resume/latest.zip"
sleep 20
