"""The seed plan: which episode seeds each use of the environments draws from.

Every seeded episode the package runs takes its seed from one of these disjoint ranges, so a
model is never tested, validated or compared on an episode it trained on:

======================  ===================================  ====================================
range                   used by                              constant
======================  ===================================  ====================================
0 onwards               the final test (``panda-rapier       :data:`TEST_FIRST_SEED`
                        eval``, ``evaluate``'s default)
500,000,000 onwards     the periodic validations of a run    :data:`VALIDATION_FIRST_SEED`
1e9 to 2e9              ``panda-rapier train``'s training    :data:`TRAIN_FIRST_SEED`,
                        environments and demonstrations      :data:`TRAIN_SEED_STRIDE`
2e9 to 3e9              the observation normaliser's expert  :data:`FIT_FIRST_SEED`,
                        episodes; RLlib's runs               :data:`RLLIB_FIRST_SEED`
3e9 onwards             the recorded Minari datasets         :data:`DEMOS_FIRST_SEED`
======================  ===================================  ====================================

The modules that seed episodes read their constants from here (no torch, no Ray).
"""

from __future__ import annotations

__all__ = [
    "DEMOS_FIRST_SEED",
    "FIT_FIRST_SEED",
    "MAX_RUN_SEED",
    "RLLIB_FIRST_SEED",
    "RLLIB_SEED_STRIDE",
    "TEST_FIRST_SEED",
    "TRAIN_FIRST_SEED",
    "TRAIN_SEED_STRIDE",
    "VALIDATION_FIRST_SEED",
]

#: First seed of the final test episodes (``panda-rapier eval``: seeds ``0, 1, ...``).
TEST_FIRST_SEED = 0
#: First seed of the periodic evaluations during training (validation).
VALIDATION_FIRST_SEED = 500_000_000
#: First seed of the training episodes (run seed 0): a run with seed ``s`` seeds its
#: environments and the expert's demonstrations from ``TRAIN_FIRST_SEED + TRAIN_SEED_STRIDE *
#: s`` (a resumed run's environments from that plus the steps already done).
TRAIN_FIRST_SEED = 1_000_000_000
#: Distance between the training seeds of consecutive run seeds.
TRAIN_SEED_STRIDE = 1_000_000
#: First seed of the scripted expert's episodes the observation normaliser's statistics are
#: taken from (:func:`panda_rapier.learning.normalization.fit_normalizers`).
FIT_FIRST_SEED = 2_000_000_000
#: RLlib's seed (``config.seed``) of run seed 0. Run seeds ``s`` use
#: ``RLLIB_FIRST_SEED + RLLIB_SEED_STRIDE * s``: from 2e9 to 3e9, apart from the final test
#: seeds, the validation seeds, the training seeds and the Minari datasets' (the same start
#: as :data:`FIT_FIRST_SEED`).
RLLIB_FIRST_SEED = 2_000_000_000
#: Distance between the RLlib seeds of consecutive run seeds: room for up to a million
#: training EnvRunners, and RLlib's evaluation runners' ``+ 1_000_000``, without reaching the
#: next run seed's.
RLLIB_SEED_STRIDE = 2_000_000
#: Run seeds of RLlib runs are ``0 <= seed < MAX_RUN_SEED`` (the range ends at 3e9; RLlib also
#: seeds numpy's global generator with it, which takes seeds below 2**32).
MAX_RUN_SEED = 500
#: First seed of recorded episodes (``panda-rapier demos``, the Minari datasets).
DEMOS_FIRST_SEED = 3_000_000_000
