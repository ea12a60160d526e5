"""The cross-engine suite's verdict layer (compare/validate.py): paired and
yes/no comparisons, the power analysis that decides which comparisons gate,
the planted-error detection table and the false-alarm count, on synthetic
runs with known answers."""
import numpy as np
import pytest

from compare import validate
from compare.validate import (MARGINS, MUTANTS, SUITES, Case, compare_rows, design_of, design_power, design_table,
                              detection_table, false_alarm_summary, mutant_sets, required_runs)


def runs(values, key="slope_deg"):
    return [{"seed": s + 1, "ok": True, key: v} for s, v in enumerate(values)]


def test_paired_rows_equal_up_to_noise_are_equivalent():
    rng = np.random.default_rng(3)
    base = rng.normal(17.0, 2.0, 12)  # a large spread shared by the pair (same packings)
    a = runs(base + rng.normal(0, 0.3, 12))
    b = runs(base + rng.normal(0, 0.3, 12))
    r = compare_rows("slope_deg", a, b, paired=True)
    assert r["verdict"] == "equivalent" and r["paired"]
    # unpaired, the shared spread is not removed: the same runs cannot be shown equivalent within 1.5
    assert compare_rows("slope_deg", a, b, paired=False)["verdict"] != "equivalent"


def test_a_shift_beyond_the_margin_is_different():
    rng = np.random.default_rng(4)
    base = rng.normal(17.0, 1.0, 10)
    r = compare_rows("slope_deg", runs(base), runs(base + 4.0 + rng.normal(0, 0.3, 10)))
    assert r["verdict"] == "different" and r["difference"] == pytest.approx(4.0, abs=0.3)


def test_pairs_use_only_seeds_defined_in_both_rows():
    a = runs([10.0, None, 12.0, 14.0], key="formation_rotations")
    b = runs([10.5, 11.0, None, 14.5], key="formation_rotations")
    r = compare_rows("formation_rotations", a, b)
    assert (r["n_a"], r["n_b"]) == (2, 2)
    assert r["difference"] == pytest.approx(0.5)
    assert r["a"]["undefined"] == 1 and r["b"]["undefined"] == 1


def test_yes_no_observables_compare_fractions():
    a = runs([True] * 10, key="rose")
    b = runs([False] * 10, key="rose")
    r = compare_rows("rose", a, b)
    assert r["verdict"] == "different" and r["difference"] == -1.0
    assert compare_rows("rose", a, a)["verdict"] == "equivalent"


def test_required_runs_reach_the_power_target():
    for obs, spread in (("slope_deg", 0.8), ("phi_max", 2.7), ("formation_rotations", 8.9), ("rose", 1.0)):
        n = required_runs(obs, spread)
        assert design_power(obs, spread, n) >= validate.POWER
        assert design_power(obs, spread, n - 1) < validate.POWER


def test_a_comparison_gates_only_with_power():
    case = Case("c", "drum", "scenes/drum/A.toml", [], list(range(1, 11)), [],
                design={("", "slope_deg"): 0.8, ("", "formation_rotations"): 8.9})
    assert design_of(case, "", "slope_deg", 10)["gating"]
    d = design_of(case, "", "formation_rotations", 10)
    assert not d["gating"] and d["power"] < 0.5 and "reported" in d["why"]
    assert not design_of(case, "", "bands_final", 10)["gating"]  # no designed spread


def test_every_suite_observable_has_a_margin_and_a_design():
    for suite, cases in SUITES.items():
        for case in cases:
            for variant, observables in case.compared.items():
                for k in observables:
                    assert k in MARGINS, (suite, case.name, k)
                    assert (variant, k) in case.design, (suite, case.name, variant, k)
            # every variant named in the case is one it runs (box: f"{f:g}Hz", so 3 Hz is "3Hz")
            names = {v for v, _ in case.variants()}
            assert set(case.compared) <= names, (suite, case.name, set(case.compared) - names)
            assert {v for v, _ in case.design} <= names, (suite, case.name)


def test_the_quick_suite_gates_the_three_headline_observables():
    quick = {c.name: c for c in SUITES["quick"]}
    gating = {(d["case"], d["variant"], d["observable"]) for d in design_table("quick") if d["gating"]}
    assert ("drum_short", "", "slope_deg") in gating
    assert ("drum_short", "", "bands_final") in gating
    # the rise: none below the threshold (gating), and every engine's own threshold test (gating)
    assert ("box_rise", "2.6Hz", "rose") in gating
    assert quick["box_rise"].threshold == ("3.2Hz", "2.6Hz")


def test_mutant_overrides_come_from_the_resolved_scene():
    drum = SUITES["quick"][0]
    assert mutant_sets(drum, "native-linear", "coulomb_half") == ["contact.mu_max=0.25"]
    assert mutant_sets(drum, "native-linear", "omega_0.9") == ["drum.omega=0.45"]
    assert mutant_sets(drum, "native-linear", "amplitude_1.8") is None  # a box-only error
    box = SUITES["quick"][1]
    assert mutant_sets(box, "native-leapfrog", "amplitude_1.8") == ["shaking.amplitude=1.8"]
    assert mutant_sets(box, "native-leapfrog", "inertia") == ["particles.inertia_factor=0.25"]
    assert set(MUTANTS) >= {"wall_friction_big_half", "coulomb_half", "inertia", "damping_double",
                            "wall_friction_off", "amplitude_1.8", "gravity_5pc", "omega_0.9"}


def mutant_result(mutant, obs, effect, margin, verdict, gating=True):
    return {"mutant": mutant, "case": "drum_short", "variant": "", "row": "native-linear", "observable": obs,
            "gating": gating, "effect": effect, "margin": margin, "verdict": verdict,
            "detected": verdict == "different", "fails_suite": verdict != "equivalent"}


def test_detection_table_lists_missed_errors():
    res = [mutant_result("coulomb_half", "slope_deg", -6.6, 1.5, "different"),
           mutant_result("coulomb_half", "bands_final", -2.0, 1.0, "inconclusive"),
           mutant_result("damping_double", "slope_deg", 0.7, 1.5, "different"),  # caught below the margin
           mutant_result("omega_0.9", "slope_deg", -0.5, 1.5, "equivalent"),
           mutant_result("omega_0.9", "formation_rotations", -9.0, 5.0, "equivalent", gating=False)]
    t = {d["mutant"]: d for d in detection_table(res)}
    assert t["coulomb_half"]["effect_beyond_margin"] == ["drum_short native-linear slope_deg",
                                                         "drum_short native-linear bands_final"]
    assert t["coulomb_half"]["detected"] == ["drum_short native-linear slope_deg"]
    assert t["coulomb_half"]["missed"] == ["drum_short native-linear bands_final"]
    assert t["coulomb_half"]["suite_fails"]
    assert t["damping_double"]["effect_beyond_margin"] == [] and t["damping_double"]["detected"]
    assert t["omega_0.9"]["missed"] == [] and not t["omega_0.9"]["suite_fails"]  # non-gating effects not counted


def test_false_alarm_summary_counts_per_comparison_and_per_repeat():
    res = []
    for rep in range(20):
        res.append({"case": "box_rise", "row": "native-leapfrog", "repeat": rep, "variant": "3.2Hz",
                    "observable": "phi_max", "gating": True, "verdict": "different" if rep == 3 else "equivalent"})
        res.append({"case": "box_rise", "row": "native-leapfrog", "repeat": rep, "variant": "3.2Hz",
                    "observable": "rose", "gating": True, "verdict": "inconclusive" if rep in (3, 4) else "equivalent"})
    s = false_alarm_summary(res, 20)
    assert s["per_comparison"]["box_rise 3.2Hz native-leapfrog phi_max"]["different"] == 1
    assert s["per_comparison"]["box_rise 3.2Hz native-leapfrog rose"]["inconclusive"] == 2
    pair = s["per_pair"]["box_rise native-leapfrog"]
    assert pair == {"repeats": 20, "any_different": 1, "all_equivalent": 18}


def test_false_alarm_seeds_are_fresh_and_disjoint():
    for case in SUITES["quick"]:
        for variant, _ in case.variants():
            seen = {s for v, _ in case.variants() for e in (None, *case.engine_seeds) for s in case.seeds_of(v, e)}
            for rep in range(20):
                for g in (0, 1):
                    s = set(validate.false_alarm_seeds(case, variant, rep, g))
                    assert len(s) == len(case.seeds_of(variant)) and not (s & seen)
                    seen |= s


def test_seeds_per_variant_and_engine():
    box = Case("b", "box", "scenes/box/f3.0_big.toml", [], [1, 2, 3], ["native-leapfrog", "lammps", "native-viscel", "yade"],
               variant_seeds={"3.2Hz": [1, 2, 3, 4, 5]}, engine_seeds={"yade": [1, 2]})
    assert box.seeds_of("2.6Hz", "native") == [1, 2, 3]
    assert box.seeds_of("3.2Hz", "native") == [1, 2, 3, 4, 5]
    assert box.seeds_of("3.2Hz", "yade") == [1, 2]
    assert box.paired_runs("3.2Hz", "native-leapfrog", "lammps") == 5
    assert box.paired_runs("3.2Hz", "native-viscel", "yade") == 2
    assert box.paired_runs("2.6Hz", "native-viscel", "yade") == 2
    box.engine_seeds = {"yade": {"3.2Hz": [1, 2, 3, 4]}}
    assert box.seeds_of("3.2Hz", "yade") == [1, 2, 3, 4]
    assert box.seeds_of("2.6Hz", "yade") == [1, 2, 3]  # no entry for the variant: the variant's seeds
    assert box.paired_runs("3.2Hz", "native-viscel", "yade") == 4


@pytest.mark.parametrize("suite", ["quick", "full"])
def test_each_suite_passes_a_correct_engine_reliably(suite):
    # A failed run must mean a difference, not bad luck: at the designed
    # spreads, engines that are truly the same pass every gating comparison
    # with probability SUITE_PASS or more.
    assert validate.pass_probability(design_table(suite)) >= validate.SUITE_PASS


def test_the_quick_suite_sizes_each_pair_by_the_seeds_both_rows_run():
    table = design_table("quick")
    # the sample size of each pair is the seeds both its rows run
    top = {d["pair"]: d for d in table if d["variant"] == "3.2Hz" and d["observable"] == "top_time_s"}
    assert top["native-leapfrog vs lammps"]["n"] == 20 and top["native-leapfrog vs lammps"]["gating"]


def test_pass_probability_is_the_product_of_the_gating_powers():
    table = [{"gating": True, "power": 0.9}, {"gating": True, "power": 0.5}, {"gating": False, "power": 0.1}]
    assert validate.pass_probability(table) == pytest.approx(0.45)


def test_box_grid_table_counts_rises_without_convection():
    """The frequency grid's table: per row the convection and rise onsets and
    how many risen disks had no convection (the paper: convection is always
    present when segregation happens); one planted run that rose without
    convecting is counted."""
    box = next(c for c in SUITES["full"] if c.name == "box")

    def run(seed, rose, conv):
        return {"seed": seed, "ok": True, "rose": rose, "convecting": conv, "phi_max": 30.0 if conv else 0.5,
                "bed_height": 55.0}
    grid = {"2.6Hz": [(False, False)] * 8, "2.8Hz": [(False, True)] * 6 + [(True, True)] * 2,
            "3Hz": [(True, True)] * 6 + [(False, True)] * 2, "3.2Hz": [(True, True)] * 7 + [(True, False)]}
    c = {"kind": "box", "case": box,
         "variants": {v: {"native-leapfrog": {"runs": [run(i + 1, r, k) for i, (r, k) in enumerate(x)]}}
                      for v, x in grid.items()}}
    validate._summarise_rows(c)
    c["thresholds"] = validate.box_thresholds(c)
    del c["case"]
    text = validate.report_markdown({"verdict": "pass", "failures": [], "comparisons": [], "cases": {"box": c}})
    line = next(l for l in text.splitlines() if l.startswith("| box | native-leapfrog |"))
    cells = [x.strip() for x in line.strip("|").split("|")]
    assert cells[4] == "16 of 32" and cells[5] == "1"
    assert cells[2].startswith("2.70 Hz")  # convection crosses one half between 2.6 (0/8) and 2.8 Hz (8/8)
    assert cells[3].startswith("2.9")  # the rise crosses one half between 2.8 (2/8) and 3.0 Hz (6/8)


def test_html_report_shows_the_rises_without_convection(tmp_path):
    """The HTML report's grid table counts the one packing (of eight at
    3.2 Hz) whose disk rose without convection."""
    from compare.report_html import write_report
    box = next(c for c in SUITES["full"] if c.name == "box")
    runs = [{"seed": i + 1, "ok": True, "rose": True, "convecting": i != 7, "phi_max": 30.0, "bed_height": 55.0}
            for i in range(8)]
    still = [dict(r, rose=False, convecting=False) for r in runs]
    c = {"kind": "box", "case": box, "scene": box.scene, "sets": box.sets, "seeds": box.seeds,
         "variants": {"2.6Hz": {"native-leapfrog": {"runs": still}}, "3.2Hz": {"native-leapfrog": {"runs": runs}}}}
    validate._summarise_rows(c)
    c["thresholds"] = validate.box_thresholds(c)
    del c["case"]
    write_report({"suite": "full", "created": "now", "verdict": "pass", "failures": [], "comparisons": [],
                  "thresholds": [], "cases": {"box": c}}, tmp_path)
    html = (tmp_path / "report.html").read_text()
    assert "<th>risen without convection</th>" in html
    rows = [r for r in html.split("<tr>") if r.startswith("<td>native-leapfrog</td>") and r.count("<td>") == 4]
    assert len(rows) == 1 and rows[0].split("</tr>")[0].endswith("<td>1</td>")


def test_a_threshold_test_gates_only_where_its_design_has_power():
    """The full suite's box grid (the disk on the floor, eight packings, rising
    in about 0.45 of them within 60 s at 3.2 Hz) cannot show a threshold with
    power: its test is reported and a miss does not fail the suite; the
    box_threshold case (the disk 15 cm up) gates every row."""
    full = {c.name: c for c in SUITES["full"]}
    d = validate.threshold_design(full["box"], "native-leapfrog")
    assert not d["gating"] and 0.4 < d["power"] < 0.6 and "reported" in d["why"]
    for row in full["box_threshold"].rows:
        assert validate.threshold_design(full["box_threshold"], row)["gating"], row
    assert not any(full["box_threshold"].compared.values())  # it compares nothing pairwise

    def case_runs(k, n):
        return {"runs": [{"seed": i + 1, "ok": True, "rose": i < k} for i in range(n)]}
    for name, k_above, expect_gating, expect_present in (("box", 3, False, False),
                                                          ("box_threshold", 12, True, True)):
        case = full[name]
        n_above = len(case.seeds_of("3.2Hz", "native"))
        c = {"case": case, "variants": {"3.2Hz": {"native-leapfrog": case_runs(k_above, n_above)},
                                        "2.6Hz": {"native-leapfrog": case_runs(0, len(case.seeds_of("2.6Hz", "native")))}}}
        (t,) = validate._thresholds(name, c, {"native-leapfrog"})
        assert t["gating"] is expect_gating and t["present"] is expect_present


def test_planted_error_rows_get_no_threshold_test_of_their_own():
    """A suite run with --mutants has rows such as native-leapfrog+gravity_5pc
    beside the case's own rows; the threshold tests cover the case's rows only."""
    case = {c.name: c for c in SUITES["full"]}["box"]

    def runs(k, n):
        return {"runs": [{"seed": i + 1, "ok": True, "rose": i < k} for i in range(n)]}
    rows = ("native-leapfrog", "native-leapfrog+gravity_5pc", "native-leapfrog@r0.0")
    c = {"case": case, "variants": {"3.2Hz": {r: runs(4, 8) for r in rows}, "2.6Hz": {r: runs(0, 8) for r in rows}}}
    assert [t["row"] for t in validate._thresholds("box", c, {"native-leapfrog"})] == ["native-leapfrog"]


def test_the_full_suite_gates_each_engines_rise_threshold():
    table = design_table("full")
    rows = {d["pair"] for d in table if d["observable"] == "rise threshold" and d["gating"]}
    assert rows == {"native-leapfrog", "lammps", "native-viscel", "yade"}
    assert all(d["case"] == "box_threshold" for d in table if d["observable"] == "rise threshold" and d["gating"])


def test_no_planted_errors_where_nothing_is_compared():
    jobs = validate.mutant_jobs("full", "/nonexistent", ["gravity_5pc"], cases=["box_threshold"])
    assert jobs == []
