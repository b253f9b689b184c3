"""``bench bias``: the true bias of the mean over seeds with both noises removed, and the verdict per group."""
import numpy as np
import pytest

from manylights.bench.bias import BIAS_CELLS, judge, true_bias
from manylights.bench.targets import CELLS


def test_true_bias_removes_the_renders_and_the_references_noise():
    rng = np.random.default_rng(1)
    truth = rng.uniform(0.5, 1.5, (24, 24, 3))
    ref_var = np.full_like(truth, 1e-4)
    ref = truth + rng.normal(0.0, 1e-2, truth.shape)
    # 16 renders with a 4% bias (a darker image) and 10% per-pixel noise: the raw error of their mean is larger.
    renders = truth * 0.96 + rng.normal(0.0, 0.1, (16,) + truth.shape)
    m = renders.mean(axis=0)
    assert np.linalg.norm(m - ref) / np.linalg.norm(ref) > 0.045
    b = true_bias(renders, ref, ref_var)
    assert b["bias"] == pytest.approx(0.04, abs=0.004)
    assert 0.0 < b["bias_se"] < 0.004
    unbiased = true_bias(truth + rng.normal(0.0, 0.1, (16,) + truth.shape), ref, ref_var)
    assert unbiased["bias"] < 0.01
    with pytest.raises(ValueError, match=">= 2 renders"):
        true_bias(renders[:1], ref, ref_var)


def test_a_group_covers_its_bias_within_a_factor_two_or_half_a_percent():
    assert judge([0.05, 0.07, 0.09], 0.04)            # median 7% against 4%: within 2x
    assert not judge([0.09, 0.10, 0.11], 0.04)        # 10% against 4%
    assert not judge([0.0, 0.0, 0.01], 0.04)          # an estimate that misses the bias
    assert judge([0.0, 0.0, 0.004], 0.003)            # small: within 0.5% absolute
    assert judge([0.0, 0.0, 0.0], 0.016, 0.024)       # a bias the seeds cannot tell from 0
    assert not judge([0.0, 0.0, 0.0], 0.057, 0.021)   # 5.7% +- 2.1%: at least 1.5%, and the estimate says 0
    assert judge([0.2, 0.2, 0.2], 0.06, 0.02)         # within 2x of 10%, the top of the truth's interval


def test_every_bias_cell_is_a_targets_cell():
    assert set(BIAS_CELLS) <= set(CELLS)


def test_the_upper_bound_of_a_run_is_the_probes_or_rebuilt_from_its_estimates():
    from manylights.bench.bias import upper_bound

    assert upper_bound({"bias_upper": 0.07, "error_estimate": 0.2, "variance_estimate": 0.1}) == 0.07
    # The variance part is subtracted at its lower bound, 0.0158 sigma^2 at 90% (one degree of freedom).
    assert upper_bound({"error_estimate": 0.17, "variance_estimate": 0.15}) == pytest.approx(
        np.sqrt(0.17**2 - 0.015791 * 0.15**2), rel=1e-4)
    assert upper_bound({"error_estimate": 0.01, "variance_estimate": 0.15}) == 0.0
