"""Tests of the lumped thermal network and the thermal-drift simulator.

Reference problems (documented, fixed):

* ``single_node`` — one 7 kJ/K mass cooled to ambient through 5.8 W/K: time constant
  C/G = 20.1 min, steady rise Q/G.
* ``two_node_chain`` — ambient –G1– node 1 –G2– node 2 with heat Q into node 2: steady rises
  Q/G1 and Q/G1 + Q/G2 (series resistances).
* ``stiff_three_node`` — capacities from 2 kJ/K to 700 kJ/K (time constants from minutes to
  hours), two boundaries; checked against scipy's implicit ODE solver.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from svrqp.exceptions import ProblemError, SingularSystemError
from svrqp.machine.cycles import (
    CycleSegment,
    duration_min,
    operation_at,
    run_stop,
    speed_steps,
    warm_up_cool_down,
)
from svrqp.machine.network import LumpedNetwork
from svrqp.machine.thermal import (
    EFFECTS,
    MachineStructure,
    Sensor,
    ThermalConfig,
    simulate_thermal,
)
from svrqp.machine.signals import first_order_lag


def single_node(capacity_J_K: float = 7000.0, conductance_W_K: float = 5.8) -> LumpedNetwork:
    return LumpedNetwork(
        ("mass",), np.array([capacity_J_K]), np.zeros((1, 1)), ("ambient",),
        np.array([[conductance_W_K]]),
    )


def two_node_chain(g1: float = 4.0, g2: float = 2.5) -> LumpedNetwork:
    return LumpedNetwork(
        ("inner", "outer"), np.array([3e4, 5e3]), np.array([[0.0, g2], [g2, 0.0]]),
        ("ambient",), np.array([[g1], [0.0]]),
    )


def stiff_three_node() -> LumpedNetwork:
    G = np.array([[0.0, 3.0, 0.0], [3.0, 0.0, 8.0], [0.0, 8.0, 0.0]])
    G_b = np.array([[4.0, 0.0], [12.0, 0.0], [22.0, 1.5]])
    return LumpedNetwork(("spindle", "headstock", "column"), np.array([2e3, 9e4, 7e5]), G,
                         ("ambient", "coolant"), G_b)


# ---------------------------------------------------------------- network: closed forms


def test_steady_state_of_series_chain_matches_closed_form():
    q_W, g1, g2 = 30.0, 4.0, 2.5
    net = two_node_chain(g1, g2)
    expected = np.array([q_W / g1, q_W / g1 + q_W / g2])
    np.testing.assert_allclose(net.steady_state(np.array([0.0, q_W]), np.array([0.0])), expected,
                               rtol=1e-12)
    # a long simulation from cold reaches the same state
    inputs = np.tile([0.0, q_W, 0.0], (4000, 1))
    theta = net.simulate(inputs, 5.0, np.zeros(2))
    np.testing.assert_allclose(theta[-1], expected, rtol=1e-9)


def test_step_response_has_configured_time_constant():
    capacity, conductance, q_W = 7000.0, 5.8, 40.0
    tau_min = capacity / conductance / 60.0
    net = single_node(capacity, conductance)
    dt = 0.25
    theta = net.simulate(np.tile([q_W, 0.0], (800, 1)), dt, np.zeros(1))[:, 0]
    t = np.arange(theta.size) * dt
    final = q_W / conductance
    t63 = np.interp(1 - np.exp(-1), theta / final, t)  # theta rises monotonically
    assert t63 == pytest.approx(tau_min, rel=0.05)
    np.testing.assert_allclose(theta, final * (1 - np.exp(-t / tau_min)), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(net.time_constants_min(), [tau_min], rtol=1e-12)


def test_default_machine_time_constants_lie_in_realistic_ranges():
    taus = MachineStructure().network().time_constants_min()
    assert 10 <= taus[0] <= 40  # spindle
    assert any(30 <= tau <= 120 for tau in taus[1:-1])  # headstock
    assert 180 <= taus[-1] <= 720  # column


def test_exact_update_matches_implicit_ode_solver():
    net = stiff_three_node()
    A, B = net.state_matrices()
    u = np.array([50.0, 20.0, 0.0, 3.0, -2.0])  # heats (W) then ambient, coolant deviations (K)
    theta0 = np.array([1.0, 0.5, 0.2])
    theta = net.simulate(np.tile(u, (120, 1)), 2.0, theta0)
    reference = solve_ivp(lambda _t, x: A @ x + B @ u, (0, 240.0), theta0, method="Radau",
                          t_eval=np.arange(121) * 2.0, rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(theta, reference.y.T, rtol=1e-7, atol=1e-8)


def test_energy_balance_heat_in_equals_stored_plus_lost():
    net = stiff_three_node()
    dt = 0.02
    t = np.arange(15000) * dt  # 300 min
    heat = np.stack([40.0 * (t < 120), 25.0 * np.ones_like(t), np.zeros_like(t)], axis=1)
    boundary = np.stack([1.5 * np.sin(t / 60.0), -1.0 * np.ones_like(t)], axis=1)
    theta = net.simulate(np.hstack([heat, boundary]), dt, np.zeros(3))
    heat_in_J = heat.sum() * dt * 60.0  # inputs are held over each step
    stored_J = net.capacity_J_K @ (theta[-1] - theta[0])
    # outflow: trapezoid over the step of theta, with the step-held boundary temperature
    flow_W = 0.5 * (net.boundary_heat_flow_W(theta[:-1], boundary)
                    + net.boundary_heat_flow_W(theta[1:], boundary))
    lost_J = flow_W.sum() * dt * 60.0
    assert heat_in_J == pytest.approx(stored_J + lost_J, rel=1e-5)


def test_steady_state_heat_in_equals_heat_out():
    net = stiff_three_node()
    heat = np.array([60.0, 10.0, 5.0])
    boundary = np.array([2.0, -1.0])
    theta = net.steady_state(heat, boundary)
    assert net.boundary_heat_flow_W(theta, boundary).sum() == pytest.approx(heat.sum(), rel=1e-12)


def test_isolated_node_has_no_steady_state():
    G = np.array([[0.0, 1.0], [1.0, 0.0]])
    net = LumpedNetwork(("a", "b"), np.array([1.0, 1.0]), G, ("ambient",), np.zeros((2, 1)))
    with pytest.raises(SingularSystemError, match="no conductive path"):
        net.steady_state(np.ones(2), np.zeros(1))


def test_network_rejects_bad_parameters():
    with pytest.raises(ProblemError, match="capacity"):
        single_node(capacity_J_K=-1.0)
    with pytest.raises(ProblemError, match="symmetric"):
        LumpedNetwork(("a", "b"), np.ones(2), np.array([[0.0, 1.0], [2.0, 0.0]]), ("amb",),
                      np.ones((2, 1)))


def test_first_order_lag_step_is_exact():
    dt, tau = 0.5, 3.0
    step = np.r_[0.0, np.ones(40)]
    lagged = first_order_lag(step, dt, tau)
    t = np.arange(step.size - 1) * dt  # time since the step took effect
    np.testing.assert_allclose(lagged[1:], 1 - np.exp(-t / tau), atol=1e-12)
    np.testing.assert_array_equal(first_order_lag(step, dt, 0.0), step)


# ---------------------------------------------------------------- cycles


def test_operation_at_follows_segments_and_is_zero_outside():
    cycle = run_stop(3000.0, 10.0, 5.0, repeats=2, axis_duty_pct=40.0)
    speed, duty = operation_at(cycle, np.array([-1.0, 0.0, 9.9, 10.0, 15.0, 29.9, 30.0]))
    np.testing.assert_array_equal(speed, [0, 3000, 3000, 0, 3000, 0, 0])
    np.testing.assert_array_equal(duty, [0, 40, 40, 0, 40, 0, 0])


def test_cycle_builders():
    warm = warm_up_cool_down(6000.0, warm_min=240.0, cool_min=60.0)
    assert duration_min(warm) == 300.0
    np.testing.assert_array_equal(operation_at(warm, np.array([10.0, 250.0]))[0], [6000.0, 0.0])
    steps = speed_steps([1000.0, 2000.0, 4000.0], minutes_each=20.0)
    np.testing.assert_array_equal(operation_at(steps, np.array([5.0, 25.0, 45.0]))[0],
                                  [1000.0, 2000.0, 4000.0])


# ---------------------------------------------------------------- the machine simulator


@pytest.fixture(scope="module")
def default_run():
    """The default machine: 4 h at 6000 rpm with 30 % axis duty, then 2 h stopped, seed 7."""
    return simulate_thermal(ThermalConfig(), seed=7)


def test_output_contract_columns_and_units(default_run):
    df = default_run
    assert df.columns[0] == "time_min"
    for name in ("speed_rpm", "T1_C", "T9_C", "coolant_C", "nut_C", "ambient_C", "error_um",
                 "noise_um", *(f"effect_{e}_um" for e in EFFECTS)):
        assert name in df.columns
    assert np.all(np.diff(df["time_min"]) == 1.0)
    assert df["time_min"].iloc[-1] == 360.0


def test_error_is_sum_of_effects_plus_noise(default_run):
    df = default_run
    effects = df[[f"effect_{e}_um" for e in EFFECTS]].sum(axis=1)
    np.testing.assert_allclose(df["error_um"], effects + df["noise_um"], rtol=0, atol=1e-12)


def test_magnitudes_are_those_of_a_real_spindle(default_run):
    df = default_run
    assert 15 < df["error_um"].max() < 80  # tens of micrometres
    rise = df["true_spindle_C"].max() - df["true_spindle_C"].iloc[0]
    assert 3 < rise < 20
    assert df["noise_um"].std() == pytest.approx(0.3, rel=0.2)


@pytest.mark.parametrize("effect", EFFECTS)
def test_turning_an_effect_off_removes_exactly_its_contribution(default_run, effect):
    off = simulate_thermal(replace(ThermalConfig(), **{effect: 0.0}), seed=7)
    column = f"effect_{effect}_um"
    assert np.any(np.abs(default_run[column]) > 0.05)  # the effect is there when on
    np.testing.assert_array_equal(off[column], 0.0)
    np.testing.assert_allclose(off["error_um"], default_run["error_um"] - default_run[column],
                               rtol=0, atol=1e-9)
    for other in EFFECTS:
        if other != effect:
            np.testing.assert_allclose(off[f"effect_{other}_um"],
                                       default_run[f"effect_{other}_um"], rtol=0, atol=1e-9)


def test_effect_scale_is_linear(default_run):
    half = simulate_thermal(replace(ThermalConfig(), spindle_heating=0.5), seed=7)
    np.testing.assert_allclose(half["effect_spindle_heating_um"],
                               0.5 * default_run["effect_spindle_heating_um"], atol=1e-9)


def test_same_seed_same_data_other_seed_other_noise(default_run):
    again = simulate_thermal(ThermalConfig(), seed=7)
    other = simulate_thermal(ThermalConfig(), seed=8)
    np.testing.assert_array_equal(again.to_numpy(), default_run.to_numpy())
    assert not np.allclose(other["noise_um"], default_run["noise_um"])
    np.testing.assert_array_equal(other["effect_spindle_heating_um"],
                                  default_run["effect_spindle_heating_um"])


def test_ideal_sensors_read_the_node_they_sit_on():
    config = replace(ThermalConfig(), sensor_lag=0.0, sensor_noise=0.0, measurement_noise=0.0)
    df = simulate_thermal(config, seed=1)
    np.testing.assert_allclose(df["T4_C"], df["true_headstock_C"], atol=1e-12)
    np.testing.assert_allclose(df["bed_C"], df["true_column_C"], atol=1e-12)
    np.testing.assert_array_equal(df["noise_um"], 0.0)


def test_sensors_are_correlated_but_not_identical(default_run):
    corr = default_run[["T1_C", "T7_C", "T8_C", "coolant_C", "T9_C"]].corr()
    assert corr.loc["T1_C", "T7_C"] > 0.5  # speed drives every machine temperature
    assert corr.loc["coolant_C", "T9_C"] > 0.3  # coolant follows ambient
    assert corr.to_numpy()[np.triu_indices(5, 1)].max() < 0.999


def test_progress_is_reported_up_to_completion():
    seen = []
    simulate_thermal(replace(ThermalConfig(), soak_h=1.0), seed=0, progress=seen.append)
    assert seen[-1] == 1.0 and seen == sorted(seen)


def test_config_rejects_invalid_values():
    with pytest.raises(ProblemError, match="spindle_heating"):
        ThermalConfig(spindle_heating=-1.0)
    with pytest.raises(ProblemError, match="integer multiple"):
        ThermalConfig(dt_min=0.4, sample_min=1.0)
    with pytest.raises(ProblemError, match="sum to 1"):
        Sensor("T1", {"spindle": 0.5})
    with pytest.raises(ProblemError, match="unknown location"):
        Sensor("T1", {"gearbox": 1.0})
    with pytest.raises(ProblemError, match="duration_min"):
        CycleSegment(0.0, 1000.0)
