"""The excitation's report (psmforce.cli.excitation.py): better conditioned than a random
motion and the paper's free motion, each segment's excited parameters computed from its
information, and what known weights add."""

from __future__ import annotations

import numpy as np
import pytest

from psmforce.cli.excitation import build, check_arguments
from psmforce.identification.prior_design import DESIGNED as NAMES  # what a design informs


@pytest.fixture(scope="module")
def built():
    return build(0.5, 2, (0.05,))


def test_the_excitation_is_better_conditioned_than_random_and_paper_motion(built):
    _, report = built
    cn = report["condition_number"]
    assert cn["excitation"] < cn["random"]
    assert cn["excitation"] < cn["paper_free"]
    assert report["log_det"]["excitation"] > report["log_det"]["random"]
    assert report["bench"]["min_hex10_fz_n"] > report["bench"]["safe_compression_n"]


def test_each_segment_says_what_it_excites_from_its_information(built):
    exc, report = built
    shares = np.array([[s["information_share"][n] for n in NAMES] for s in report["segments"]])
    assert shares.sum(axis=0) == pytest.approx(1.0)
    clench = [s for s in report["segments"] if s["kind"] == "clench"]
    # only a clench drives the blade pairs slack: the blade radius is theirs
    assert any("pulley_radius_blade" in s["excites"] for s in clench)
    assert all(set(s["excites"]) <= set(NAMES) for s in report["segments"])
    assert len(report["segments"]) == len(exc.segments)


def test_known_weights_pin_down_what_free_motion_cannot(built):
    _, report = built
    kw = report["known_weights"]["paper_free"]
    assert kw["not_identifiable_without"]              # the paper's free motion leaves some
    assert kw["needed"] != 0
    # the weights leave fewer parameters unidentified (the radii: pitch and blade loads)
    assert len(kw["greedy"][-1]["not_identifiable"]) < len(kw["not_identifiable_without"])
    first = kw["greedy"][0]
    assert first["log_det_gain"] > 0
    ratios = [r for gain in kw["each_alone"].values() for r in gain["standard_error_ratio"].values()]
    assert min(ratios) < 1.0 and max(ratios) <= 1.0 + 1e-9  # information only adds


@pytest.mark.parametrize("minutes, seed, weights, option", [
    (0.1, 0, (), "--minutes"), (31.0, 0, (), "--minutes"), (1.0, -1, (), "--seed"),
    (1.0, 0, (0.5,), "--known-weights"), (1.0, 0, (0.001,), "--known-weights")])
def test_bad_arguments_are_refused_naming_the_option(minutes, seed, weights, option):
    with pytest.raises(ValueError, match=option):
        check_arguments(minutes, seed, weights)


def test_paired_poses_hang_each_bend_and_its_opposite():
    """``--paired-poses``: sixteen orientations, each followed by its opposite bend (what the
    load path's identification needs, docs/ati_free.md 4.1); the report names them."""
    from psmforce.cli.excitation import (WEIGHT_WRIST_POSES, WEIGHT_WRIST_POSES_PAIRED,
                                         known_weights)
    poses = np.array(WEIGHT_WRIST_POSES_PAIRED)
    assert len(poses) == 16 and len({tuple(p) for p in poses}) == 16
    assert np.array_equal(poses[1::2, 1:], -poses[0::2, 1:])  # pitch and yaw mirrored
    assert np.array_equal(poses[1::2, 0], poses[0::2, 0])     # at the same roll
    report = known_weights((0.05,), {}, poses=WEIGHT_WRIST_POSES_PAIRED)
    assert len(report["orientations"]) == 16 and not report["left_out_unsafe"]
    assert len(known_weights((0.05,), {})["orientations"]) == len(WEIGHT_WRIST_POSES)


def test_the_load_path_needs_the_weights_for_the_geometry_and_no_hold_shows_the_capstans_growth(
        built):
    """What ``calibrate --known-loads`` identifies reads the cables from the load path: free
    space demands no cable torque there, so the radii and the pretension wait for the weights;
    a static hold never moves the wrist, so the capstan's growth with the configuration (which
    acts through the friction's direction) gets no information from any hold."""
    _, report = built
    gains = report["known_weights"]["load_path"]["excitation"]
    without = set(gains["not_identifiable_without"])
    assert {"pulley_radius_pitch", "pulley_radius_blade", "cable_radius",
            "pretension_total"} <= without
    left = set(gains["not_identifiable_with_all"])
    assert left == set(gains["greedy"][-1]["not_identifiable"])
    assert {"pulley_radius_pitch", "cable_radius"}.isdisjoint(left)   # the weights pin them
    assert {"capstan_pitch_gain", "capstan_roll_gain"} <= left and gains["needed"] is None
    ratios = [r for g in gains["each_alone"].values() for r in g["standard_error_ratio"].values()]
    assert None in ratios                   # no information before or after: no ratio
    assert min(r for r in ratios if r is not None) < 1.0
