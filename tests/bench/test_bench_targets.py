"""``bench targets``: the true error with the reference's noise removed, and the verdict per cell."""
import numpy as np
import pytest

from manylights.bench.targets import CELLS, judge, true_error


def test_true_error_removes_the_references_noise():
    rng = np.random.default_rng(0)
    truth = rng.uniform(0.5, 1.5, (32, 32, 3))
    var = np.full_like(truth, 1e-4)
    ref = truth + rng.normal(0.0, 1e-2, truth.shape)            # a reference with noise of variance 1e-4
    image = truth * 1.03                                          # 3% off the converged image
    assert np.linalg.norm(image - ref) / np.linalg.norm(ref) > 0.031  # the noise adds to the raw error
    assert true_error(image, ref, var) == pytest.approx(0.03, rel=0.02)
    assert true_error(ref, ref, var) == 0.0


def run(seed, claimed, true, estimate):
    return {"seed": seed, "claimed": claimed, "true": true, "estimate": estimate, "seconds": 1.0,
            "probe_seconds": 0.1}


def test_a_cell_keeps_its_word_only_within_the_tolerances():
    ok = [run(s, True, 0.04, 0.045) for s in range(7)] + [run(7, True, 0.07, 0.045)]  # one above 1.25e
    assert judge(ok, 0.05)["keeps_its_word"] and judge(ok, 0.05)["claimed_over_1_25x"] == 1
    two = ok[:6] + [run(6, True, 0.07, 0.045), run(7, True, 0.07, 0.045)]
    assert not judge(two, 0.05)["keeps_its_word"]
    far = ok[:7] + [run(7, True, 0.11, 0.045)]                   # above 2e
    assert not judge(far, 0.05)["keeps_its_word"] and judge(far, 0.05)["claimed_over_2x"] == 1
    low = ok[:7] + [run(7, False, 0.2, 0.09)]                    # unclaimed, estimate below half the truth
    v = judge(low, 0.05)
    assert not v["keeps_its_word"] and (v["unclaimed_estimate_below_half"], v["unclaimed_estimate_above_2x"]) == (1, 0)
    edges = run(0, True, 0.08, 0.045) | {"true_without_edges": 0.04}  # judged without the edge pixels
    assert judge([edges], 0.05)["claimed_over_1_25x"] == 0
    assert judge(ok, 0.05)["bound_covers"] == 7 and judge([edges], 0.05)["bound_covers"] == 1


def test_every_cell_has_its_reference():
    from conftest import REFERENCES, REPO

    for xml, _, _, ref, _ in CELLS.values():
        assert (REPO / xml).is_file() and (REFERENCES / f"{ref}.exr").is_file(), (xml, ref)
