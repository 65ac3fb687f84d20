"""The default sampler of a seeded search: TPE seeded per trial.

Imported only where Optuna is installed (by :func:`run_search`), so that
:mod:`skthermal.model_selection` itself does not need it.
"""

import numpy as np
import optuna


def trial_seed(random_state, number):
    """The sampler seed of trial ``number`` of a search seeded with
    ``random_state``."""
    return int(np.random.SeedSequence([random_state, number]).generate_state(1)[0])


class TrialSeededSampler(optuna.samplers.BaseSampler):
    """Optuna's ``TPESampler``, seeded anew for every trial from
    ``(random_state, trial number)``.

    Trial numbers are unique in a study (the storage hands them out), so
    workers started together with the same seed draw different points, a
    resumed study draws new ones, and a search in one process draws the same
    points at every run. The TPE model is rebuilt from the study's trials at
    every draw, as ``TPESampler`` does anyway.

    Parameters
    ----------
    random_state : int
        The search's seed.
    """

    def __init__(self, random_state):
        self.random_state = random_state
        self._per_trial = {}

    def _sampler(self, trial):
        number = trial.number
        sampler = self._per_trial.get(number)
        if sampler is None:
            seed = trial_seed(self.random_state, number)
            sampler = self._per_trial.setdefault(
                number, optuna.samplers.TPESampler(seed=seed)
            )
        return sampler

    def infer_relative_search_space(self, study, trial):
        return self._sampler(trial).infer_relative_search_space(study, trial)

    def sample_relative(self, study, trial, search_space):
        return self._sampler(trial).sample_relative(study, trial, search_space)

    def sample_independent(self, study, trial, param_name, param_distribution):
        return self._sampler(trial).sample_independent(
            study, trial, param_name, param_distribution
        )

    def before_trial(self, study, trial):
        self._sampler(trial).before_trial(study, trial)

    def after_trial(self, study, trial, state, values):
        self._sampler(trial).after_trial(study, trial, state, values)
        self._per_trial.pop(trial.number, None)

    def reseed_rng(self):
        # The draws are seeded per trial: there is no stream to reseed.
        pass
