"""Calibration of the harvest model to a field sheet (berryshaker.study.field_calibration, ``berryshaker calibrate``)
on the small harvest machine (one branch class) with a 2 x 2 design: the clearance C (0.1, 0.2 mm) and the drive
speed (100, 150 r/min), which moves the removal along its S-curve and so separates the strengths from the yield.

* the simulator is the virtual harvest's own implementation: its responses at scaled strengths equal the virtual
  harvest's expectation of a description with those strengths, and a stem-load table recomputed at scaled strengths
  is the cached one divided by the scale (homogeneity of degree -1);
* simulation-based calibration with the field's noise: sheets of counted field tests (fresh machine starts and
  bushes the emulator never saw) at parameters drawn from the prior, with a further multiplicative field noise the
  likelihood does not assume in that form, are calibrated, and the 90 % intervals cover the true values at about the
  nominal rate (the full study: benchmarks/studies/calibration_coverage.py);
* a sheet with a strong measured effect the model does not produce: the verdict names it and the predictions follow
  it;
* the emulator's 90 % intervals hold the simulator at settings that were not simulated (the joint GP), as at the
  simulated ones; a saved emulator predicts as the fitted one;
* a sheet from the reference parameters is recovered (``calibrate`` through the command on a ``doe plan`` sheet), the
  same sheet as a statistics package writes it calibrates too, twice to the same result, and ``--from`` predicts from
  the saved calibration;
* errors name the field and the fix.

Coupled runs are shared through one session cache (:func:`calibration_cache`).
"""


import json

import numpy as np
import pytest

from berryshaker.experiment.field_sheet import parse_factor
from berryshaker.harvest.bruising import median_height
from berryshaker.study import field_calibration as fc

FACTORS = ("C=0.1,0.2mm", "speed=100,150rpm")
R_SIM = 3  # simulated starts per setting
SHEET_REPLICATES = 2
SBC_SHEETS = 12
POOL = 3  # fresh coupled starts per setting that synthetic sheets draw their replicates from
FIELD_NOISE = 0.15  # CV of the further multiplicative field noise of the synthetic sheets


@pytest.fixture(scope="session")
def calibration_cache(tmp_path_factory):
    """One run cache for every coupled start of this module (and a later caller with the same jobs)."""
    return tmp_path_factory.mktemp("calibration-cache")


@pytest.fixture(scope="module")
def runner(calibration_cache):
    from berryshaker.runs.runner import SweepRunner

    with SweepRunner(workers=1, cache_dir=calibration_cache, progress=False) as r:  # in this process: compiled once
        yield r


@pytest.fixture(scope="module")
def small(small_harvest_machine):
    return small_harvest_machine


@pytest.fixture(scope="module")
def reference_sheet(small, runner):
    """A ``doe plan`` sheet (L4, two factors, two replicates) from the simulator at the described parameters."""
    return fc.synthetic_sheet(small, runner, [parse_factor(f) for f in FACTORS], array="L4",
                              replicates=SHEET_REPLICATES)


@pytest.fixture(scope="module")
def trained(small, runner, reference_sheet):
    """Simulator at the sheet's settings (training starts, and the sheet's own fresh starts as a pool) and the emulator."""
    sheet = fc.read_sheet(reference_sheet.to_csv(index=False), small)
    sim = fc.Simulator(small, sheet.targets)
    idx = [sim.setting_index(x) for x in sheet.settings_si]
    settings = sorted(set(idx))
    seeds = fc.training_starts(small, R_SIM)
    sim.run(runner, settings, seeds)
    params = fc.parameters_for(small)
    responses = list(sheet.observations)
    emulator = fc.Emulator(sheet.targets, responses, 0, R_SIM)
    u = fc.latin_hypercube(48, 1)
    emulator.fit([sim.settings[i] for i in settings], u, *fc._train(sim, responses, settings, seeds, u, params))
    check = fc._emulator_check(sim, emulator, settings, seeds, fc.latin_hypercube(8, 2), params)
    for gps in emulator.local:
        for r in responses:
            gps[r].mse_log_mean = check[r].mse_log_mean
    # a pool of POOL fresh machine starts per setting (never trained on); each sheet draws its own bushes from them
    fresh = fc.fresh_starts(len(settings) * POOL)
    pool = {s: fresh[i * POOL:(i + 1) * POOL] for i, s in enumerate(settings)}
    sim.run_starts(runner, [(s, k) for s in settings for k in pool[s]], "fresh pool")
    return {"sheet": sheet, "sim": sim, "idx": idx, "settings": settings, "emulator": emulator, "params": params,
            "pool": pool, "check": check, "responses": responses}


def test_simulator_is_the_virtual_harvests_implementation(small, runner):
    """Scaled strengths, bond CV, unripe fraction, bruise height, Miner exponent and strike share through
    :meth:`Simulator.responses` equal the
    virtual harvest's expectation (:func:`berryshaker.harvest.virtual.start_responses`) of a description with those
    values on tables at those strengths; a table recomputed at scaled strengths is the cached one / a."""
    from berryshaker.config import machine_from_dict
    from berryshaker.harvest.virtual import MACHINE, machine_start, start_responses, stem_force_envelope_run
    from berryshaker.study.l9 import replicate_envelopes, replicate_jobs
    from berryshaker.study.runs import replicate_run

    targets = [fc.factor_target(small, f.name, f.unit, f.levels) for f in map(parse_factor, FACTORS)]
    sim = fc.Simulator(small, targets)
    s = sim.setting_index([0.2e-3, 150 * 2 * np.pi / 60])
    seeds = fc.training_starts(small, R_SIM)
    sim.run(runner, [s], seeds)
    h = small.harvest
    th = {"ripe_pull": 0.6, "unripe_pull": 1.5, "bond_cv": 0.3, "unripe_fraction": 0.2,
          "yield_per_bush": 1.1, "bruise_height": 0.9, "miner_exponent": 5.0, "strike_probability": 0.3,
          "pedicel_stiffness": small.plant.fruit.pedicel.stiffness}
    names = list(fc.calibrated_responses())
    got, var = sim.responses(s, seeds, np.array([[th[n] for n in fc.PARAMETER_NAMES]]), names)
    data, clearance = fc.setting_data(small.model_dump(mode="json"), small, targets, sim.settings[s])
    at_setting = machine_from_dict(data)
    d = at_setting.model_dump()
    d["harvest"].update(ripe_pull=0.6, ripe_shear=0.6 * h.ripe_shear / h.ripe_pull, unripe_pull=1.5,
                        unripe_shear=1.5 * h.unripe_shear / h.unripe_pull, bond_cv=0.3, unripe_fraction=0.2,
                        yield_per_bush=1.1, safe_drop_height_padded=0.9 / float(median_height(1.0, h.safe_fractile, h.bruise_cv)),
                        miner_exponent=5.0, strike_probability=0.3)
    scaled = machine_from_dict(d)
    outs = runner.values(replicate_run, replicate_jobs(at_setting, clearance, seeds, data=data))
    for k, (env, start) in enumerate(replicate_envelopes(at_setting, outs, seeds)):
        # the cached tables are at the described strengths: their load channels / a are the tables at a x strength
        from berryshaker.harvest.virtual import miner_channels

        e = [t.copy() for t in env]
        for t in e:
            t[..., miner_channels(True)] *= h.ripe_pull / 0.6
            t[..., miner_channels(False)] *= h.unripe_pull / 1.5
        ref = start_responses(scaled, e, start)
        assert got[0, k] == pytest.approx([ref["expected"][n] for n in names], rel=1e-9)
        assert np.sqrt(var[0, k]) == pytest.approx([ref["count_sd"][n] for n in names], rel=1e-6)
    # homogeneity: the coupled run recomputed with the scaled strengths gives the cached table / a exactly
    table, _ = stem_force_envelope_run(scaled, clearance, 1.0, machine_start(scaled, (seeds[0], MACHINE, 0)))
    cached = np.array(outs[0]["envelopes"][0])
    from berryshaker.harvest.virtual import miner_channels

    for ripe, a in ((True, h.ripe_pull / 0.6), (False, h.unripe_pull / 1.5)):
        c = miner_channels(ripe)
        assert table[..., c] == pytest.approx(cached[..., c] * a, rel=1e-12)
    # the pedicel stiffness: the simulator reads the cached tables at the scaled stiffness as the virtual harvest
    # does (berryshaker.harvest.virtual.stem_force_tables), and a stiffer pedicel moves every response
    from berryshaker.harvest.virtual import HarvestParameters, expected_tally, load_grid, response_values

    k = small.plant.fruit.pedicel.stiffness
    stiff = np.array([[th[n] if n != "pedicel_stiffness" else 2 * k for n in fc.PARAMETER_NAMES]])
    got2, _ = sim.responses(s, seeds, stiff, names)
    env0 = replicate_envelopes(at_setting, outs, seeds)[0][0]
    hp = HarvestParameters(**dict(zip(fc.PARAMETER_NAMES, stiff[0])))
    ref2 = response_values(expected_tally(at_setting, load_grid(at_setting, env0), hp), names)
    assert got2[0, 0] == pytest.approx([ref2[n] for n in names], rel=1e-9)
    assert np.all(np.abs(got2[0, 0] / got[0, 0] - 1) > 1e-3)


def test_a_response_added_to_the_table_is_calibrated(small, trained, reference_sheet):
    """A calibrated harvest response registered as one row of the table (tests/extra_response.py) is read from the
    sheet's column, simulated through the virtual harvest's own implementation, emulated and in the likelihood."""
    from extra_response import registered, ripe_left

    sim, params = trained["sim"], trained["params"]
    with registered(ripe_left(calibrated=True)):
        responses = list(fc.calibrated_responses())
        assert responses[-1] == "ripe_left"
        seeds = fc.training_starts(small, R_SIM)
        theta = fc.theta_of(fc.latin_hypercube(6, 5), params)
        mean, var = sim.responses(0, seeds, theta, responses)
        assert np.all(mean[..., -1] > 0) and np.all(var[..., -1] > 0)
        df = reference_sheet.copy()
        df["ripe_left_kg_min"] = 3.0 + 0.1 * df["replicate"]
        sheet = fc.read_sheet(df.to_csv(index=False), small)
        assert "ripe_left" in sheet.observations
        em = fc.Emulator(sheet.targets, responses, 0, R_SIM)
        u = fc.latin_hypercube(12, 1)
        settings = sorted(set(trained["idx"]))
        em.fit([sim.settings[i] for i in settings], u, *fc._train(sim, responses, settings, seeds, u, params))
        stats = fc.SheetStatistics.of(em, sheet.settings_si, sheet.observations)
        post = fc.sample_posterior(em, stats, params, R_SIM, 0, responses, steps=60, walkers=40)
        assert post["hyper"].shape[1] == 2 * len(responses)


def test_emulator_error_on_held_out_parameters_is_small_against_the_noise(trained):
    """Held-out theta points at the simulated settings: the efficiency's and the damage's mean within half a
    replicate SD; every error is carried into the likelihood (mse_log_mean)."""
    chk = trained["check"]
    assert chk["efficiency"].rmse_over_sd < 0.5 and chk["damage"].rmse_over_sd < 0.5
    assert all(chk[r].mse_log_mean > 0 for r in chk)


def _field_sheet(trained, theta: dict, rng, draw: int, effect: dict | None = None, replicates: int = SHEET_REPLICATES,
                 noise: float = FIELD_NOISE) -> "fc.Sheet":
    """A sheet of counted field tests at ``theta``: each run's replicates distinct fresh machine starts of the pool,
    each with its own bushes (field draw ``draw``), times a further lognormal field noise of CV ``noise`` and, with
    ``effect`` (factor index -> level value (SI) -> factor), a measured effect the model does not produce."""
    sim, sheet0 = trained["sim"], trained["sheet"]
    obs = {r: np.zeros((len(trained["idx"]), replicates)) for r in trained["responses"]}
    sig = np.sqrt(np.log1p(noise**2))
    for i, s in enumerate(trained["idx"]):  # the replicates of a run: distinct machine starts, fresh bushes
        for j, k in enumerate(rng.choice(trained["pool"][s], replicates, replace=False)):
            res = sim.field_results(s, [int(k)], theta, trained["responses"], draw=draw)[0]
            res = res * np.exp(-0.5 * sig**2 + sig * rng.standard_normal(res.shape))
            for col, r in enumerate(trained["responses"]):
                f = 1.0
                for jf, by in (effect or {}).items():
                    f *= by.get(round(float(sheet0.settings_si[i, jf]), 12), 1.0) if r == "efficiency" else 1.0
                obs[r][i, j] = np.nan_to_num(res[col]) * f
    return fc.Sheet(sheet0.targets, sheet0.settings_si, obs, replicates)


def test_simulation_based_calibration_covers_with_field_noise(trained):
    """Simulation-based calibration (Talts et al. 2018) on sheets that carry a field's noise: 12 sheets of counted
    field tests at theta drawn from the prior, the replicates of a run distinct fresh machine starts with their own
    bushes, times a further multiplicative field noise (CV 0.15) that the likelihood models only as an additive
    field-noise term, calibrated with the trained emulator (400 steps of 32 walkers).  Nominal coverage of the 90 %
    intervals over 12 x 8 = 96 checks is 86.4; the eight of a sheet are not independent, so the test accepts at least
    0.80 of them (77; measured 92): too low is overconfidence, the failure that matters (the full study, 48 checks at
    the command's sizes: benchmarks/studies/calibration_coverage.py)."""
    params = trained["params"]
    rng = np.random.default_rng(44)
    covered, total, per_param = 0, 0, np.zeros(len(params))
    for k in range(SBC_SHEETS):
        theta = fc.theta_of(rng.uniform(0.02, 0.98, (1, len(params))), params)[0]
        th = dict(zip(fc.PARAMETER_NAMES, theta))
        sheet = _field_sheet(trained, th, rng, draw=k + 1)
        stats = fc.SheetStatistics.of(trained["emulator"], sheet.settings_si, sheet.observations)
        post = fc.sample_posterior(trained["emulator"], stats, params, R_SIM, k, trained["responses"], steps=400,
                                   walkers=32)
        lo, hi = np.quantile(post["theta"], [0.05, 0.95], axis=0)
        inside = (lo <= theta) & (theta <= hi)
        covered += int(inside.sum())
        total += len(params)
        per_param += inside
    print("SBC coverage", covered, "/", total, dict(zip(fc.PARAMETER_NAMES, per_param)))
    assert covered >= 0.80 * total, (covered, dict(zip(fc.PARAMETER_NAMES, per_param)))


def test_a_measured_effect_the_model_does_not_produce_is_named_and_followed(small, trained):
    """A sheet at the described parameters (three replicates, the counting noise only) whose efficiency is 40 % above
    the model at C = 0.1 mm and 40 % below at 0.2 mm (a strong measured effect the model does not produce): the
    residuals' C effect is beyond the noise and the verdict names C; the posterior
    predictions at the two C levels differ in the measured direction by a good part of the measured difference
    (measured: 2.5 of 4.9 kg/min; the rest is the discrepancy's shrinkage towards the model on four runs of a machine
    whose one branch class makes each start scatter by about 30 %); the yield is not pulled away by it (its interval
    still holds the true value)."""
    from berryshaker.study.field_calibration.workflow import _discrepancies, predictions

    params, emulator = trained["params"], trained["emulator"]
    rng = np.random.default_rng(7)
    effect = {0: {round(0.1e-3, 12): 1.4, round(0.2e-3, 12): 0.6}}
    sheet = _field_sheet(trained, fc.described_values(small), rng, draw=99, effect=effect, replicates=POOL, noise=0.0)
    stats = fc.SheetStatistics.of(emulator, sheet.settings_si, sheet.observations)
    post = fc.sample_posterior(emulator, stats, params, R_SIM, 5, trained["responses"], steps=600, walkers=32)
    verdict = _discrepancies(sheet, stats, emulator, params, post, trained["responses"], fc.DISCREPANCY_SCALE)
    eff = verdict["efficiency"]
    assert any(e.factor == "C" and e.beyond_noise for e in eff.residual_effects), eff
    assert "the model does not produce" in eff.verdict and "C" in eff.verdict
    preds, _ = predictions(emulator, stats, sheet.targets, sheet.settings_si, fc.level_sets(sheet.targets), 4,
                           post["u"][:300], post["hyper"][:300], params, trained["responses"], R_SIM, 1)
    by_c = {}
    for p in preds:
        by_c.setdefault(p.setting["C"].value, []).append(p.responses["efficiency"].mean)
    measured = {c: float(np.mean([sheet.observations["efficiency"][i].mean() for i in range(4)
                                  if round(sheet.settings_si[i, 0] * 1e3, 6) == c])) for c in (0.1, 0.2)}
    pred = {c: float(np.mean(v)) for c, v in by_c.items()}
    assert pred[0.1] - pred[0.2] > 0.4 * (measured[0.1] - measured[0.2]) > 0, (pred, measured)
    y = fc.PARAMETER_NAMES.index("yield_per_bush")
    lo, hi = np.quantile(post["theta"][:, y], [0.05, 0.95])
    assert lo <= small.harvest.yield_per_bush <= hi


#: untested settings inside the 2 x 2 (mm, r/min): its centre and the midpoints of its edges
UNTESTED = ((0.15, 125), (0.10, 125), (0.20, 125), (0.15, 100), (0.15, 150))
COVERAGE_DRAWS = 12  # posterior draws per setting at which the emulator is checked against the simulator


def test_emulator_intervals_cover_the_simulator_at_untested_settings(small, runner, trained):
    """The emulator's 90 % interval of the simulated replicate mean (mean +- 1.645 sqrt(emulator variance)) holds the
    simulator's value at settings that were not simulated (the joint GP) as it does at the simulated ones: 12
    posterior draws (none trained on) at the 2 x 2's centre and edge midpoints, 60 checks per response, the
    simulator run there from the training starts (the emulator's target; no other noise enters).  The joint GP is
    fitted as :func:`calibrate` fits it but with no check settings, the weakest case: its error term is then the
    per-setting GPs' held-out error alone (:meth:`Emulator.joint_mse`).  With the GP's own variance as its error
    (before that floor) the efficiency was covered in 45 of 60 checks, the unripe rate in 54 and the damage in 48;
    with it 58, 60 and 60.  Accepted: at least 51 of 60 (0.85) per response; the draws of a setting share its GP, so the checks are
    not independent."""
    import copy

    from berryshaker.study.field_calibration.workflow import _fit_joint

    sim, params, sheet, settings = trained["sim"], trained["params"], trained["sheet"], trained["settings"]
    emulator = copy.copy(trained["emulator"])  # its own joint GP; the per-setting GPs are shared, not changed
    seeds = fc.training_starts(small, R_SIM)
    stats = fc.SheetStatistics.of(emulator, sheet.settings_si, sheet.observations)
    post = fc.sample_posterior(emulator, stats, params, R_SIM, 3, trained["responses"], steps=400, walkers=32)
    order = np.random.default_rng(4).permutation(len(post["u"]))
    _fit_joint(sim, emulator, settings, [], seeds, post["u"][order[:16]], None, params)
    u = post["u"][order[16:16 + COVERAGE_DRAWS]]
    theta = fc.theta_of(u, params)
    theta[:, fc.PARAMETER_NAMES.index("yield_per_bush")] = 1.0  # the emulator's efficiency is per kg of yield
    untested = [sim.setting_index((c * 1e-3, n * 2 * np.pi / 60)) for c, n in UNTESTED]
    sim.run(runner, untested, seeds, "untested settings")
    covered = {}
    for label, group in (("tested", settings), ("untested", untested)):
        for col, r in enumerate(trained["responses"]):
            inside = 0
            for s in group:
                simulated = fc.start_statistics(*sim.responses(s, seeds, theta, trained["responses"]))[0][:, col]
                mean, var, _, _ = emulator.predict(np.repeat([sim.settings[s]], len(u), axis=0), u, r)
                inside += int(np.sum(np.abs(simulated - mean) <= 1.645 * np.sqrt(var)))
            covered[label, r] = (inside, len(group) * len(u))
    print("emulator 90 % interval coverage", covered)
    for r in trained["responses"]:
        inside, total = covered["untested", r]
        assert inside >= 0.85 * total, (r, covered)


def test_fast_gp_prediction_is_sklearns(trained):
    """:class:`FittedGP` predicts what scikit-learn's ``predict(return_std=True)`` does (latent variance, no noise)."""
    g = trained["emulator"].local[0]["efficiency"].mean_gp
    from berryshaker.study.field_calibration.priors import mean_parameters

    x = fc.latin_hypercube(10, 9, len(mean_parameters("efficiency")))  # the efficiency GP's parameters
    mean, var = g.predict(x)
    m_ref, s_ref = g.gp.predict(x, return_std=True)
    noise = g.gp.kernel_.k2.noise_level * float(np.atleast_1d(g.gp._y_train_std)[0]) ** 2
    assert mean == pytest.approx(m_ref, rel=1e-9, abs=1e-9)
    assert var == pytest.approx(np.maximum(s_ref**2 - noise, 0.0), rel=1e-6, abs=1e-9)


def test_grid_prediction_is_the_per_row_prediction(trained):
    """:meth:`Emulator.predict_grid` (the simulated settings' GPs stacked, one batched evaluation; an untested setting
    through the joint GP) gives what :meth:`Emulator.predict` gives row by row, to round-off."""
    em, sim = trained["emulator"], trained["sim"]
    settings = np.array([sim.settings[i] for i in trained["settings"]]
                        + [0.5 * (np.asarray(sim.settings[trained["settings"][0]])
                                  + np.asarray(sim.settings[trained["settings"][-1]]))])  # the last: untested
    u = fc.latin_hypercube(7, 5)
    for order in (np.arange(len(settings)), np.array([len(settings) - 1, 1, 0])):  # all; untested first, reordered
        s = settings[order]
        for r in trained["responses"]:
            for with_var in (True, False):
                grid = em.predict_grid(s, u, r, with_var)
                rows = em.predict(np.tile(s, (len(u), 1)), np.repeat(u, len(s), axis=0), r, with_var)
                for g, a in zip(grid, rows):
                    assert g.shape == (len(u), len(s))
                    np.testing.assert_allclose(g, a.reshape(len(u), len(s)), rtol=1e-9, atol=1e-12)


def test_the_joint_baseline_is_the_per_setting_gps_average(trained):
    """The joint GP's baseline (the per-setting GPs' average, evaluated once per distinct draw and batched over the
    settings) is every per-setting GP evaluated at every row and averaged, to round-off, with rows repeated."""
    from berryshaker.study.field_calibration.priors import PARAMETER_NAMES, count_parameters, mean_parameters

    em = trained["emulator"]
    u = fc.latin_hypercube(6, 7)
    u = np.vstack([u, u[::-1], u[:2]])  # repeated rows, as a prediction over settings gives them
    for r in trained["responses"]:
        cols = [PARAMETER_NAMES.index(p) for p in mean_parameters(r)]
        ccols = [PARAMETER_NAMES.index(p) for p in count_parameters(r)]
        want = (np.mean([g[r].mean_gp.predict(u[:, cols], False)[0] for g in em.local], axis=0),
                np.mean([g[r].logsd_gp.predict(u[:, cols], False)[0] for g in em.local], axis=0),
                np.mean([g[r].logcsd_gp.predict(u[:, ccols], False)[0] for g in em.local], axis=0))
        for got, w in zip(em._local_average(u, r), want):
            assert got.shape == (len(u),)
            np.testing.assert_allclose(got, w, rtol=1e-10, atol=1e-12)


def test_a_saved_emulator_predicts_as_the_fitted_one(trained, tmp_path):
    """The emulator's state written to an .npz and read back (no pickle) rebuilds every GP with its fitted
    hyperparameters: the same predictions, bit for bit."""
    em = trained["emulator"]
    fc.save_state(tmp_path / "s.npz", {"emulator": em.state()})
    (tmp_path / fc.STATE_FILE).write_bytes((tmp_path / "s.npz").read_bytes())
    back = fc.Emulator.from_state(fc.load_state(tmp_path)["emulator"])
    x = np.repeat([trained["sim"].settings[0]], 5, axis=0)
    u = fc.latin_hypercube(5, 3)
    for r in trained["responses"]:
        for a, b in zip(em.predict(x, u, r), back.predict(x, u, r)):
            assert np.array_equal(a, b)


@pytest.fixture(scope="module")
def small_toml(small, tmp_path_factory):
    """The small machine as a TOML file (the reference file with one branch class): the command's jobs are the
    library's, so the runs come from the cache."""
    import tomllib
    from importlib import resources

    text = (resources.files("berryshaker") / "drives" / "groove_cam" / "reference.toml").read_text("utf-8")
    from fast_machine import with_values

    text = with_values(text, {"harvest.branch_classes": "[1.0]"})
    assert tomllib.loads(text)["harvest"]["branch_classes"] == [1.0]
    path = tmp_path_factory.mktemp("calibrate-cli") / "small.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _invoke(*args):
    from typer.testing import CliRunner

    from berryshaker.cli import app

    return CliRunner().invoke(app, ["calibrate", *map(str, args)])


def test_command_recovers_the_reference_parameters_from_a_doe_plan_sheet(small, small_toml, runner, reference_sheet,
                                                                        tmp_path):
    """``calibrate`` on the ``doe plan`` sheet made at the described parameters: every described value inside its
    posterior 90 % interval but at most one near miss, identified parameters narrower than half their prior, predictions of every level set with
    intervals, the report folder written; ``calibration.json`` reads back as a :class:`CalibrationResult` that writes
    it again byte for byte, and ``--json`` prints the same plus the report folder."""
    sheet = tmp_path / "sheet.csv"
    reference_sheet.to_csv(sheet, index=False)
    out = tmp_path / "report"
    res = _invoke(sheet, "--config", small_toml, "--replicates", R_SIM, "--workers", 1, "--cache", runner.cache_dir,
                  "--check-settings", 1, "--emulator-points", 24, "--steps", 800, "--json", "--out", out)
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert {"parameters", "predictions", "emulator", "checks", "version", "code_sha256", "machine_si"} <= set(data)
    text = (out / "calibration.json").read_text(encoding="utf-8")
    saved = fc.CalibrationResult.from_json(json.loads(text))
    assert json.dumps(saved.to_json(), indent=2) + "\n" == text
    assert data == {**saved.to_json(), "out": str(out)}
    cal = fc.CalibrationResult.from_json(data)
    assert cal.sheet.file == str(sheet) and cal.out == str(out) and cal.checks.held_out_run.reason
    # six 90 % intervals all cover one sheet's truth with probability about 0.9^6 = 0.53, so one miss is allowed if it
    # is a near miss (within a tenth of the interval's width); coverage itself is the simulation-based test's
    misses = {n: p for n, p in cal.parameters.items() if not p.lo90 <= p.described <= p.hi90}
    assert len(misses) <= 1, misses
    for name, p in misses.items():
        assert min(abs(p.described - p.lo90), abs(p.described - p.hi90)) <= 0.1 * (p.hi90 - p.lo90), (name, p)
    for name, p in cal.parameters.items():
        if p.identified:
            assert p.hi90 - p.lo90 < 0.5 * (p.prior.hi90 - p.prior.lo90)
    assert any(p.identified for p in cal.parameters.values())
    assert len(cal.predictions) == 4 and all(p.tested for p in cal.predictions)
    for p in cal.predictions:
        for r in ("efficiency", "unripe", "damage"):
            v = p.responses[r]
            assert v.lo90 <= v.mean <= v.hi90
    assert cal.emulator.held_out_settings and cal.emulator.held_out_theta["efficiency"].rmse_over_sd < 1
    assert cal.checks.summary.total == 12 and len(cal.checks.posterior_predictive) == 12
    assert cal.recommendation.level_set in {p.level_set for p in cal.predictions}
    assert {"report.html", "calibration.json", "parameters.csv", "parameters.xlsx", "predictions.csv",
            "prior_posterior.png", fc.STATE_FILE} <= {f.name for f in out.iterdir()}
    # --from: the saved calibration predicts again, without the simulator or the sampler, the same numbers
    again = _invoke("--from", out, "--config", small_toml, "--predict", "C=0.15mm,speed=125rpm", "--json")
    assert again.exit_code == 0, again.output
    redo = json.loads(again.stdout)
    assert redo["recommendation"] == cal.recommendation.level_set
    saved_preds = {p.level_set: p.responses["efficiency"].mean for p in cal.predictions}
    for p in redo["predictions"]:
        if p["level_set"] in saved_preds:
            assert p["responses"]["efficiency"]["mean"] == pytest.approx(saved_preds[p["level_set"]], rel=1e-12)
    assert any(p["named"] for p in redo["predictions"])


def test_command_reads_a_statistics_package_sheet(small_toml, runner, reference_sheet, tmp_path):
    """The same results as a statistics package writes them (factor columns with units in the header, a replicate
    column, no run column) calibrate too, and a named setting is predicted (an extrapolation is flagged)."""
    df = reference_sheet.rename(columns={"C_mm": "C (mm)", "speed_rpm": "speed (rpm)",
                                         "efficiency_kg_min": "Efficiency (kg/min)", "unripe_rate_pct": "Unripe (%)",
                                         "damage_rate_pct": "Damage (%)"})
    df = df[["order", "C (mm)", "speed (rpm)", "replicate", "Efficiency (kg/min)", "Unripe (%)", "Damage (%)"]]
    sheet = tmp_path / "minitab.csv"
    df.rename(columns={"order": "RunOrder"}).to_csv(sheet, index=False)
    res = _invoke(sheet, "--config", small_toml, "--replicates", R_SIM, "--workers", 1, "--cache", runner.cache_dir,
                  "--check-settings", 0, "--emulator-points", 12, "--steps", 150, "--json",
                  "--predict", "speed=170rpm")
    assert res.exit_code == 0, res.output
    cal = fc.CalibrationResult.from_json(json.loads(res.stdout))
    assert cal.sheet.runs == 4 and cal.sheet.replicates == SHEET_REPLICATES
    named = [p for p in cal.predictions if p.named]
    assert len(named) == 1 and named[0].extrapolated
    assert named[0].setting["speed"].value == pytest.approx(170)
    assert cal.emulator.held_out_settings == {} and cal.out is None
    # reproducible: the same sheet and seed give the same posterior, predictions and recommendation
    twice = _invoke(sheet, "--config", small_toml, "--replicates", R_SIM, "--workers", 1, "--cache", runner.cache_dir,
                    "--check-settings", 0, "--emulator-points", 12, "--steps", 150, "--json",
                    "--predict", "speed=170rpm")
    a, b = json.loads(res.stdout), json.loads(twice.stdout)
    for d in (a, b):
        d.pop("timings_s")
        d["emulator"].pop("fit_s")
    assert a == b


def test_errors_name_the_field_and_the_fix(small_toml, reference_sheet, tmp_path):
    """Checked before any run: a factor calibrate cannot simulate, a sheet without results, a --predict factor that
    is not in the sheet, a report folder holding the user's files."""
    bad = reference_sheet.rename(columns={"C_mm": "X_mm", "C_level": "X_level"})
    p = tmp_path / "bad.csv"
    bad.to_csv(p, index=False)
    res = _invoke(p, "--config", small_toml)
    assert res.exit_code == 2 and "factor 'X'" in res.output and "clearance pair" in res.output
    empty = reference_sheet.copy()
    for c in ("efficiency_kg_min", "unripe_rate_pct", "damage_rate_pct"):
        empty[c] = np.nan
    p = tmp_path / "empty.csv"
    empty.to_csv(p, index=False)
    res = _invoke(p, "--config", small_toml)
    assert res.exit_code == 2 and "no field results" in res.output
    p = tmp_path / "sheet.csv"
    reference_sheet.to_csv(p, index=False)
    res = _invoke(p, "--config", small_toml, "--predict", "A=0.3mm")
    assert res.exit_code == 2 and "'A' is not a factor of the sheet" in res.output
    res = _invoke(p, "--config", small_toml, "--predict", "C=0.3")
    assert res.exit_code == 2 and "unit" in res.output
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    res = _invoke(p, "--config", small_toml, "--out", mine)
    assert res.exit_code == 2 and "not empty" in res.output and (mine / "notes.txt").read_text() == "mine"


def _small_result(held_out_done: bool = True) -> "fc.CalibrationResult":
    """A hand-made calibration result (one parameter, two level sets, one response): the records without a run."""
    prior = fc.PriorSummary(distribution="lognormal", text="lognormal, central 90 % 0.26-0.72 N", lo90=0.26, hi90=0.72,
                            source="Kong et al. 2014", tag="[published range]")
    param = fc.ParameterSummary(unit="N", prior=prior, described=0.47, posterior_mean=0.45, posterior_median=0.44,
                                lo90=0.40, hi90=0.50, width_ratio=0.22, identified=True)
    preds = [fc.Prediction(level_set=f"C={c}mm", setting={"C": fc.SettingValue(value=c, unit="mm")}, tested=True,
                           named=False, extrapolated=False,
                           responses={"efficiency": fc.ResponsePrediction(mean=m, lo90=m - 1, hi90=m + 1,
                                                                          unit="kg/min")})
             for c, m in ((0.1, 5.0), (0.2, 4.0))]
    check = fc.EmulatorCheck(rmse=0.1, replicate_sd_rms=0.5, rmse_over_sd=0.2, log_sd_rmse=0.3, mse_log_mean=0.01,
                             relative_rmse=0.1, points=8, unit="kg/min per kg of yield per bush")
    row = fc.RunCheck(run=1, setting="C=0.1mm", response="efficiency", observed_mean=5.1, lo90=4.0, hi90=6.0,
                      inside=True)
    held = (fc.HeldOutRun(done=True, run=1, rows=[row], steps=150) if held_out_done else
            fc.HeldOutRun(done=False, reason="not asked for"))
    return fc.CalibrationResult(
        parameters={"ripe_pull": param}, identified_rule=fc.IDENTIFIED_RULE,
        confounded=[fc.Confounding(parameters=["ripe_pull", "yield_per_bush"], correlation=0.7)],
        confounded_rule=fc.CONFOUNDED_RULE, predictions=preds,
        recommendation=fc.CalibrationRecommendation(level_set="C=0.1mm", score=1.0, no_difference=[], dominated=1, candidates=2,
                                         rule=fc.RECOMMENDATION_RULE, weights={"efficiency": 1.0}),
        emulator=fc.EmulatorSummary(kind="GP", joint_fitted=True, joint_points=160, training_points=48,
                                    theta_points_per_setting=24, held_out_theta={"efficiency": check},
                                    held_out_settings={}, held_out_settings_at="nowhere", check_settings=[],
                                    untested_relative_rmse={"efficiency": 0.1}, untested_error_rule="rule",
                                    fit_s=1.5),
        checks=fc.Checks(posterior_predictive=[row], summary=fc.CheckSummary(inside=1, total=1, rule="rule"),
                         held_out_run=held),
        sampler=fc.SamplerSummary(walkers=24, steps=150, burn=40, thin=6, acceptance_fraction=0.2,
                                  autocorrelation_steps=[13.0], converged=False, draws=432, package="emcee"),
        simulator=fc.SimulatorSummary(starts_per_setting=3, seeds=[0, 1, 2], settings_simulated=2,
                                      coupled_runs=6, exact="exact"),
        sheet=fc.SheetSummary(runs=2, replicates=2, responses=["efficiency"],
                              factors={"C": fc.FactorSummary(sets="C", unit="mm", levels=[0.1, 0.2])},
                              runs_identified_by="run column"),
        likelihood="normal", discrepancy=0.2, discrepancy_text="on",
        discrepancies={"efficiency": fc.ModelDiscrepancy(
            scale=5.0, unit="kg/min", field_noise=fc.HyperSummary(median=0.1, lo90=0.02, hi90=0.3, prior_scale=0.3),
            amplitude=fc.HyperSummary(median=0.05, lo90=0.01, hi90=0.2, prior_scale=0.2),
            residual_effects=[fc.ResidualEffect(factor="C", range=0.2, f=1.0, p=0.4, beyond_noise=False)],
            verdict="the model represents the sheet's efficiency")},
        limits=list(fc.LIMITS),
        timings_s=fc.Timings(simulator=1.0, emulator=2.0, sampling=3.0))


def test_calibration_result_json_form_round_trip_and_refusals():
    """The record tree writes the command's keys in order (optional keys only when set: the held-out run's
    ``reason`` or ``run``/``rows``/``steps``, the sheet's ``file``, the provenance), reads back equal, and refuses an
    unknown key or a wrong type, naming the field, at any depth."""
    import pydantic

    from berryshaker.records import field_names

    res = _small_result()
    data = res.to_json()
    assert list(data) == [k for k in field_names(fc.CalibrationResult)
                          if k not in ("package", "version", "code_sha256", "machine_si", "out")]
    assert "file" not in data["sheet"] and list(data["checks"]["held_out_run"]) == ["done", "run", "rows", "steps"]
    assert list(_small_result(False).to_json()["checks"]["held_out_run"]) == ["done", "reason"]
    assert data["predictions"][0]["responses"]["efficiency"] == {"mean": 5.0, "lo90": 4.0, "hi90": 6.0,
                                                                 "unit": "kg/min"}
    back = fc.CalibrationResult.from_json(json.loads(json.dumps(data)))
    assert back == res and isinstance(back.predictions[0].responses["efficiency"], fc.ResponsePrediction)
    assert back.checks.held_out_run.rows[0] == res.checks.posterior_predictive[0]
    with pytest.raises(pydantic.ValidationError, match="colour"):
        fc.CalibrationResult.from_json({**data, "colour": "red"})
    bad = json.loads(json.dumps(data))
    bad["predictions"][0]["responses"]["efficiency"]["median"] = 5.0
    with pytest.raises(pydantic.ValidationError, match="median"):
        fc.CalibrationResult.from_json(bad)
    bad = json.loads(json.dumps(data))
    bad["parameters"]["ripe_pull"]["identified"] = "maybe"
    with pytest.raises(pydantic.ValidationError, match="identified"):
        fc.CalibrationResult.from_json(bad)
    with pytest.raises(pydantic.ValidationError, match="timings_s"):
        fc.CalibrationResult.from_json({k: v for k, v in data.items() if k != "timings_s"})
    with pytest.raises(AttributeError):
        res.discrepancy = 0.1


def test_report_reads_the_record_by_attribute(tmp_path):
    """The report (below the study layer, so it does not import the records) renders a result record: tables,
    figures and the page, the held-out run's table or its reason."""
    from berryshaker.report.calibration import calibration_tables, write_calibration_outputs

    tables = calibration_tables(_small_result())
    assert tables["parameters"][1][0][:2] == ["ripe_pull", "N"]
    assert [r[0] for r in tables["predictions"][1]] == ["C=0.1mm", "C=0.2mm"]
    assert tables["emulator_error"][1] == [["held_out_theta", "efficiency", 0.1, 0.5, 0.2, 0.1, 0.3, 8]]
    write_calibration_outputs(_small_result(), tmp_path, "t")
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert "Recommended: C=0.1mm" in page and "calibrated without run 1" in page
    (tmp_path / "b").mkdir()
    write_calibration_outputs(_small_result(False), tmp_path / "b", "t")
    assert "No held-out run: not asked for." in (tmp_path / "b" / "report.html").read_text(encoding="utf-8")
