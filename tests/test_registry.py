"""The model registry: every name resolves to its estimator, its export kind and the command line."""

from __future__ import annotations

import pytest

from svrqp import registry
from svrqp.description import Describable
from svrqp.cli._common import MODELS, make_estimator
from svrqp.exceptions import ProblemError
from svrqp.export import crosscheck, load_schema
from svrqp.export.c_source import _FORMULA_CODE

OPTIONS = {"C": 3.0, "epsilon": 0.25, "gamma": 0.5, "degree": 4, "forgetting": 0.95, "solver": "dual_ipm"}


@pytest.mark.parametrize("spec", registry.MODELS, ids=lambda spec: spec.name)
def test_each_model_resolves_to_an_estimator_of_its_kind(spec):
    cls = spec.estimator_class()
    assert cls.__name__ == spec.class_name
    assert cls.export_kind == spec.export_kind and isinstance(spec.make(), Describable)
    assert registry.spec(spec.name) is spec and registry.spec_of_kind(spec.export_kind) is spec


@pytest.mark.parametrize("name", MODELS)
def test_every_command_line_model_is_built_through_the_registry(name):
    spec = registry.spec(name)
    estimator = make_estimator(name, **OPTIONS)
    assert type(estimator) is spec.estimator_class()
    params = estimator.get_params()
    assert {key: params[key] for key in spec.parameters} == {key: OPTIONS[key] for key in spec.parameters}


def test_every_export_kind_has_a_schema_entry_a_reference_and_c_code_for_its_formula():
    kinds = set(registry.export_kinds())
    assert set(load_schema()["properties"]["kind"]["enum"]) == kinds
    assert set(crosscheck.REFERENCES) == kinds
    assert set(_FORMULA_CODE) == {spec.formula for spec in registry.MODELS} == {
        registry.KERNEL, registry.LINEAR, registry.LEGENDRE}


def test_unknown_names_list_the_valid_ones():
    with pytest.raises(ProblemError, match="--model must be one of svr, lssvr, mlr, poly, rls, got 'forest'"):
        registry.spec("forest", "--model")
    with pytest.raises(ProblemError, match="kind must be one of epsilon_svr"):
        registry.spec_of_kind("svr")


def test_tuning_and_gap_use_the_registry_names():
    from svrqp.gap.model import make_model
    from svrqp.tuning.checks import check_model

    assert registry.baselines()[0] == registry.DEFAULT_BASELINE
    for name in registry.baselines():
        make_model(name)
    with pytest.raises(ProblemError, match="choose one of"):
        make_model("poly")
    for name in registry.tunable():
        check_model(name)
    with pytest.raises(ProblemError, match="model must be one of"):
        check_model("mlr")
