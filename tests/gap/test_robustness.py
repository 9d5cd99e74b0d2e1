"""The gap diagnosis on awkward random input: a clear error or a schema-valid report, never a crash.

Each seed draws one awkward table and call (:func:`awkward_case`): runs of 1–60 rows, uneven or
jittered sampling, times far from zero, repeated index labels, integer and partly missing or
infinite columns, targets in tiny or huge units with or without noise, train queries that split
runs or select nothing or everything, no order or no group, every baseline and surrogate kind.
Under warnings-as-errors the call must either raise the library's own :class:`SvrqpError` or
return a report whose JSON validates against the shipped schema. Bugs this generator found, each
now with a named test of its own: a run left with one real row by a train query on time (an
IndexError in the rate), an order axis restarting per run (an overflow warning in the filter
coefficients; seeds 75 and 76 here), an exact fit (the square root of a rounding error below
zero).
"""

import json
import warnings

import jsonschema
import numpy as np
import pandas as pd
import pytest

from svrqp.exceptions import SvrqpError
from svrqp.gap import GapQuestion, diagnose, load_schema


def awkward_case(seed: int) -> tuple[pd.DataFrame, dict, dict]:
    """An awkward table, the fields of its :class:`GapQuestion` and the settings of one diagnosis
    (module docstring)."""
    rng = np.random.default_rng(seed)
    parts = []
    grouped = rng.random() < 0.85  # without a group the clock runs on from run to run
    clock = 1e5 if rng.random() < 0.2 else 0.0
    for run, rows in enumerate(rng.integers(1, 80, size=int(rng.integers(1, 6)))):
        step = float(rng.choice([1.0, 0.5, 2.0, 1 / 60]))
        t = clock + np.arange(rows) * step
        if rng.random() < 0.2:
            t = t + rng.uniform(0, step / 3, rows)
        clock = 0.0 if grouped else t[-1] + step
        parts.append(pd.DataFrame({"run": run if rng.random() < 0.5 else f"r{run}", "time_min": t}))
    df = pd.concat(parts)
    if rng.random() < 0.3:
        df.index = np.zeros(len(df), int)
    n = len(df)
    df["f1_C"] = rng.normal(size=n).cumsum()
    df["f2_C"] = rng.integers(20, 25, n)
    df["c1_C"] = rng.normal(size=n).cumsum()
    df["c2_C"] = np.where(rng.random(n) < rng.choice([0, 0.3, 0.95]), np.nan, rng.normal(size=n))
    df["c3_C"] = np.where(rng.random(n) < 0.5, np.inf, 1.0) if rng.random() < 0.1 else rng.normal(size=n)
    scale = float(rng.choice([1.0, 1e6, 1e-6]))
    df["error_um"] = scale * (2 * df["f1_C"] + 0.5 * df["c1_C"] + rng.normal(size=n) * rng.choice([0.0, 0.3]))
    df["pred_um"] = scale * 2 * df["f1_C"]
    train = rng.choice(["run in (0, 'r0')", "time_min < 10", f"index < {rng.integers(0, n)}", "f1_C > 0",
                        "run not in (0, 'r0')"])
    kwargs = {"target": "error_um", "train": str(train),
              "candidates": list(rng.choice(["c1_C", "c2_C", "c3_C", "f1_C", "f2_C"], size=int(rng.integers(1, 5)),
                                            replace=False)),
              "order": None if rng.random() < 0.2 else "time_min", "group": "run" if grouped else None}
    surrogates = str(rng.choice(["rotation", "continuous"]))
    if rng.random() < 0.5:
        kwargs |= {"features": ["f1_C", "f2_C"][: int(rng.integers(1, 3))],
                   "model": str(rng.choice(["mlr", "lssvr", "svr"]))}
    else:
        kwargs["prediction"] = "pred_um"
    return df, kwargs, {"seed": seed, "surrogates": surrogates}


SEEDS = range(80)


def _outcome(seed: int):
    """The report of seed ``seed``'s case, or what it raised (warnings are errors)."""
    df, kwargs, settings = awkward_case(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            return diagnose(df, GapQuestion(**kwargs), **settings)
        except Exception as error:  # judged per seed by the test below
            return error


@pytest.fixture(scope="module")
def outcomes():
    return {seed: _outcome(seed) for seed in SEEDS}


@pytest.mark.parametrize("seed", SEEDS)
def test_awkward_input_gives_a_clear_error_or_a_valid_report(outcomes, seed):
    outcome = outcomes[seed]
    if isinstance(outcome, Exception):
        assert isinstance(outcome, SvrqpError), f"{type(outcome).__name__}: {outcome}"
    else:
        jsonschema.validate(json.loads(outcome.to_json()), load_schema())


def test_the_cases_reach_both_the_errors_and_the_reports(outcomes):
    # a generator that only ever fails the input checks would test nothing past them
    reports = sum(not isinstance(outcome, Exception) for outcome in outcomes.values())
    assert 20 <= reports <= len(SEEDS) - 20
