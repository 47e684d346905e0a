"""mkctl calibrate on what a real rig's blocked-force test shows (issue 21): which of C1 and C2 it holds when the
data cannot separate them, and the effects of model-spec section 4b (pressure friction, threshold pressure) as
calibration candidates, found on a record made by a force law written here, not by mkctl's."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mkctl.analysis.calibrate import calibrate, isometric_record
from mkctl.analysis.synth import synthesize_isometric

#: A short muscle (10 mm, 10 cm), its braid at 23 deg at rest around a 12 mm diameter.
SHORT = {"L0": 0.10, "D0": 0.010, "t0": 0.0012}
B_SHORT = 0.10 / math.cos(math.radians(23.0))
N_SHORT = math.sqrt(B_SHORT ** 2 - 0.10 ** 2) / (math.pi * 0.012)


def test_c1_is_held_when_the_free_fit_drives_it_to_zero():
    """Blocked force of a short muscle between 90 % and 100 % of L0 with C1 = 0 and C2 = 1.5 MPa: C1 and C2 cannot
    be separated; the free fit drives C1 to 0, so C1 is held there and C2 refitted (holding C2 at Table I's
    1300 Pa, as before, left 27 times the noise)."""
    truth = {"b": B_SHORT, "n": N_SHORT, "C1": 0.0, "C2": 1.5e6, "slack": 1}
    rec = synthesize_isometric(truth, known=SHORT, noise=0.5, seed=1, lengths=(0.090, 0.095, 0.100))
    record = isometric_record(rec.inputs["length"], rec.inputs["pressure"], rec.output, rec.inputs["branch"],
                              rec.known, source="short muscle")
    result = calibrate([record], effects=("slack",))
    assert result.not_identifiable == [["C1", "C2"]]
    assert result.held == {"C1": 0.0}
    assert result.fitted["C1"] == 0.0 and result.fitted["C2"] == pytest.approx(1.5e6, rel=0.02)
    note = next(n for n in result.notes if "cannot separate C1 and C2" in n)
    assert "C1 held at 0 Pa" in note and "lower bound" in note and "C2 at its start 1300 Pa" in note
    # it reaches the noise: the RMS error is what the noise alone leaves
    noise_rms = float(np.sqrt(np.mean((rec.output - rec.output_clean) ** 2)))
    assert result.rms_after < 1.1 * noise_rms
    assert not any(s["label"].startswith("final (") for s in result.steps)  # holding C1 cost nothing
