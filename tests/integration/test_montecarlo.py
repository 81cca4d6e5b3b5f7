"""Dispersed Monte Carlo of ees-drop-1: reproducibility of every case from (seed, i) whatever the
chunking and runner (in-process, 2 spawned processes, a Dask LocalCluster), the batch RK4 against
the 500 Hz Simulator, zero dispersions = nominal flight, sane statistics and the results folder."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.analysis.mc_envelopes import PERCENTILES, envelope_column
from casrecon.analysis.montecarlo import (
    INPUT_NAMES,
    OUTPUT_COLUMNS,
    Dispersions,
    draw_case,
    run_cases,
    run_montecarlo,
)
from casrecon.cli_montecarlo import run_montecarlo_command
from casrecon.scenario import Scenario
from casrecon.simulation.batch import HISTORY_CHANNELS, BatchSimulator
from casrecon.simulation.simulate import Simulator

DROP1 = PROBLEMS / "ees-drop-1"
#: Batch RK4 (dt 0.02 s) against the 500 Hz Simulator (observed: 2e-6 s and 2e-7 m/s).
TOL_TIME_S, TOL_SPEED_MPS = 0.01, 0.01


@pytest.fixture(scope="module")
def scenario():
    return Scenario.load(DROP1)


@pytest.fixture(scope="module")
def batch64():
    """Cases 0..63 of seed 11, one chunk, in this process."""
    return run_cases(DROP1, range(64), 11, Dispersions(), workers=1, chunk_size=64)


def assert_same(a: dict, b: dict, rows=slice(None)) -> None:
    assert list(a) == list(b)
    for name in a:
        np.testing.assert_array_equal(a[name][rows], b[name], err_msg=name)


def test_columns_and_seed_reproducibility(batch64):
    assert list(batch64) == ["case", *INPUT_NAMES, *OUTPUT_COLUMNS]
    assert len(batch64["case"]) == 64
    again = run_cases(DROP1, range(8), 11, Dispersions(), chunk_size=8)
    assert_same(batch64, again, slice(0, 8))
    other = run_cases(DROP1, range(8), 12, Dispersions(), chunk_size=8)
    assert not np.array_equal(other["flight_time_s"], again["flight_time_s"])


def test_case_alone_equals_case_in_batch(batch64):
    alone = run_cases(DROP1, [37], 11, Dispersions(), chunk_size=1)
    assert_same(batch64, alone, slice(37, 38))


def test_two_processes_and_chunking_give_identical_cases(batch64):
    two = run_cases(DROP1, range(64), 11, Dispersions(), workers=2, chunk_size=10)
    assert_same(batch64, two)


def test_dask_local_cluster_gives_identical_cases(batch64):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        via_dask = run_cases(DROP1, range(16), 11, Dispersions(), scheduler=cluster.scheduler_address,
                             chunk_size=5)
    assert_same(batch64, via_dask, slice(0, 16))


def test_batch_simulator_matches_500hz_simulator(scenario):
    disp = Dispersions().resolved(1.0, 0.01)
    cases = [draw_case(11, i, scenario.release_state(), scenario.truth_parameters(), disp) for i in range(3)]
    x0 = np.column_stack([c[0] for c in cases])
    p0 = np.column_stack([c[1] for c in cases])
    res = BatchSimulator(scenario.model, dt_s=0.02, batch=3).run(x0, p0)
    sim = Simulator(scenario.model, dt_s=0.002)
    for i in range(3):
        ref = sim.run(x0[:, i], p0[:, i]).summary()
        assert res.impacted[i] and ref["impacted"]
        assert abs(res.flight_time_s[i] - ref["flight_time_s"]) < TOL_TIME_S
        assert abs(res.impact_speed_mps[i] - ref["impact_speed_mps"]) < TOL_SPEED_MPS
        np.testing.assert_allclose(res.impact_state[3:6, i], ref["impact_velocity_ned_mps"], atol=TOL_SPEED_MPS)
        assert abs(res.max_alpha_t_deg[i] - ref["max_total_aoa_deg"]) < 0.5


def test_zero_dispersions_reproduce_the_nominal_flight(scenario):
    mc = run_montecarlo(DROP1, 3, seed=5, dispersions=Dispersions.none())
    ref = Simulator(scenario.model, dt_s=0.002).run(scenario.release_state(), scenario.truth_parameters()).summary()
    for name in ("h_agl_m", "vel_n_mps", "flight_time_s", "impact_speed_mps", "CA_mult", "density_factor"):
        assert np.all(mc[name] == mc[name][0]), name
    assert mc["h_agl_m"][0] == pytest.approx(1618.04)
    assert abs(mc["flight_time_s"][0] - ref["flight_time_s"]) < TOL_TIME_S
    assert abs(mc["impact_speed_mps"][0] - ref["impact_speed_mps"]) < TOL_SPEED_MPS
    assert mc.nominal["flight_time_s"] == mc["flight_time_s"][0]
    # every case is the nominal flight, so each envelope (p1, p50, p99) is the nominal history
    env = mc.histories.envelopes()
    flying = env["n_in_flight"] == 3
    assert flying.sum() == mc.histories.nominal.shape[0] == 1 + int(mc["flight_time_s"][0] / 0.1)
    for channel in HISTORY_CHANNELS:
        for p in PERCENTILES:
            np.testing.assert_allclose(env[envelope_column(channel, p)][flying],
                                       env[envelope_column(channel, "nominal")][flying], rtol=1e-6, err_msg=channel)
    assert np.all(env[envelope_column("h_agl_m", 99)][~flying] == 0.0)  # landed: on the ground
    assert np.all(np.isnan(env[envelope_column("speed_mps", 50)][~flying]))  # landed: no speed


def test_histories_are_kept_for_the_first_cases_only():
    every = run_montecarlo(DROP1, 10, seed=3, chunk_size=4)
    first = run_montecarlo(DROP1, 10, seed=3, chunk_size=4, history_cases=5)
    assert every.histories.n_cases == 10 and first.histories.n_cases == 5
    assert first.histories.nbytes == 5 * first.histories.data.shape[1] * 16
    k = first.histories.data.shape[1]
    np.testing.assert_array_equal(first.histories.data, every.histories.data[:5, :k])
    assert first.statistics()["n_history_cases"] == 5
    assert run_montecarlo(DROP1, 3, seed=3, history_dt_s=None).histories is None


def test_histories_follow_the_500hz_simulator(scenario):
    """Each case's history on the 0.1 s grid against the 500 Hz Simulator flown from the same draw."""
    mc = run_montecarlo(DROP1, 4, seed=11, history_dt_s=0.1)
    h = mc.histories
    assert h.data.dtype == np.float32 and h.dt_s == pytest.approx(0.1) and h.data.shape[2] == 4
    disp = mc.dispersions
    sim = Simulator(scenario.model, dt_s=0.002)
    for i in (0, 3):
        x0, p0 = draw_case(11, i, scenario.release_state(), scenario.truth_parameters(), disp)
        ref = sim.run(x0, p0)
        n = int(np.sum(~np.isnan(h.data[i, :, 0])))
        assert n == 1 + int(mc["flight_time_s"][i] / 0.1)  # sampled until touchdown, NaN after
        t = h.time_s[:n]
        expect = {"h_agl_m": np.interp(t, ref.time_s, ref.output("h_agl")),
                  "speed_mps": np.interp(t, ref.time_s, np.linalg.norm(ref.states[:, 3:6], axis=1)),
                  "alpha_t_deg": np.degrees(np.interp(t, ref.time_s, ref.output("alpha_t"))),
                  "pitch_deg": np.degrees(np.interp(t, ref.time_s, ref.output("pitch")))}
        for c, channel in enumerate(HISTORY_CHANNELS):
            np.testing.assert_allclose(h.data[i, :n, c], expect[channel], atol=0.02, err_msg=channel)


def test_statistics_are_sane(batch64, scenario):
    from casrecon.analysis.montecarlo import MonteCarloResult

    mc = MonteCarloResult(batch64, 11, Dispersions().resolved(1.0, 0.01), 0.02, problem="ees-drop-1")
    st = mc.statistics()
    assert st["n_impacted"] == 64
    sp, ft = st["impact_speed_mps"], st["flight_time_s"]
    # 8000 cases (benchmarks/bench_montecarlo.py): mean 41.59, sd 0.79, p1 39.97, p99 43.85 m/s
    assert 40.0 < sp["mean"] < 44.0 and 40.0 < sp["p50"] < 44.0 and 0.3 < sp["sd"] < 1.5
    assert 39.0 < sp["p1"] <= sp["p50"] <= sp["p99"] < 45.0
    assert 37.0 < ft["p1"] <= ft["p50"] <= ft["p99"] < 43.0
    assert ft["three_sigma"] == pytest.approx(3 * ft["sd"])
    # the draws have the stated sizes (loosely, 64 cases)
    assert 2.0 < np.std(batch64["h_agl_m"]) < 8.0
    assert 0.15 < np.std(batch64["CA_mult"]) < 0.55
    assert 0.15 < np.std(batch64["wind_bias_n_mps"]) < 0.55


def test_command_writes_the_folder_and_rejects_bad_input(tmp_path, capsys):
    out = tmp_path / "mc"
    assert run_montecarlo_command(DROP1, out, 12, 3, 1, None, progress=False) == 0
    stats = json.loads((out / "statistics.json").read_text())
    assert stats["n_cases"] == 12 and stats["seed"] == 3
    header = (out / "cases.csv").read_text().splitlines()[0].split(",")
    assert header[0] == "case" and "impact_speed_mps" in header and "CA_mult" in header
    assert len((out / "cases.csv").read_text().splitlines()) == 13
    assert {p.name for p in (out / "figures").iterdir()} == {"histograms.png", "speed_vs_time.png", "envelopes.png"}
    envelopes = (out / "envelopes.csv").read_text().splitlines()
    assert envelopes[0].split(",")[:5] == ["flight_time_s", "n_in_flight", "h_agl_p1_m", "h_agl_p50_m", "h_agl_p99_m"]
    assert envelopes[1].startswith("0,12,")
    capsys.readouterr()
    assert run_montecarlo_command(DROP1, tmp_path / "x", 0, 3, 1, None) == 2
    assert run_montecarlo_command(tmp_path / "missing", tmp_path / "x", 5, 3, 1, None) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "--cases" in err[0] and "missing" in err[1]
    assert not (tmp_path / "x").exists()
