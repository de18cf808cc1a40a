"""Loader for the WPI dVRK PSM recordings (Wang et al. 2019; format in shared/data/wpi_psm/README.md).

File layout: no header, 21 comma-separated columns, 200 Hz, no time column. Columns 0-6 positions,
7-13 velocities, 14-20 efforts. Inside each block: yaw (rad), pitch (rad), insertion (m), roll
(rad), then three wrist coordinates in the recorder's MOTOR space (not dVRK joints). Conversion to
dVRK joints (wrist_pitch, wrist_yaw, jaw)::

    q_dvrk   = M q_motor          dq likewise
    tau_dvrk = inv(M)^T tau_motor (virtual work: tau_motor = M^T tau_dvrk)
    M = [[1.0186, 0, 0], [-0.8306, 0.6089, 0.6089], [0, -1.2177, 1.2177]]

:class:`WpiRecording` keeps both: ``q, dq, tau`` in the recorder's coordinates (what the published
metric uses for joints 5-7) and ``to_dvrk()`` for dVRK joint space (what the rest of the library
uses, e.g. ``PSM.wrench_from_torques``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from psmforce.identification.errors import IdentificationInputError

SAMPLE_RATE_HZ = 200.0

WRIST_MOTOR_TO_DVRK = np.array([[1.0186, 0.0, 0.0],
                                [-0.8306, 0.6089, 0.6089],
                                [0.0, -1.2177, 1.2177]])
"""M: dVRK (wrist_pitch, wrist_yaw, jaw) = M @ recorder wrist motor coordinates."""

MOTOR_COORDINATES = ("yaw", "pitch", "insertion", "roll", "wrist_motor_1", "wrist_motor_2",
                     "wrist_motor_3")
"""Names of the recorder's 7 coordinates (joints 1-7 of the published table)."""


def coordinates_to_dvrk_matrix() -> np.ndarray:
    """7x7 block-diagonal map from recorder coordinates to dVRK joints (identity on joints 1-4)."""
    T = np.eye(7)
    T[4:, 4:] = WRIST_MOTOR_TO_DVRK
    return T


@dataclass(frozen=True)
class WpiRecording:
    """One WPI trajectory in the recorder's coordinates: q, dq, tau each (N, 7); 200 Hz."""

    q: np.ndarray
    dq: np.ndarray
    tau: np.ndarray
    source: str
    sample_rate_hz: float = SAMPLE_RATE_HZ

    def to_dvrk(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, dq, tau) in dVRK joint space, each (N, 7), order yaw .. jaw."""
        T = coordinates_to_dvrk_matrix()
        return self.q @ T.T, self.dq @ T.T, self.tau @ np.linalg.inv(T)


def load_wpi(path: str | Path) -> WpiRecording:
    """Read one WPI CSV; IdentificationInputError naming the file and the problem if unusable."""
    path = Path(path)
    if not path.is_file():
        raise IdentificationInputError(f"{path}: no such WPI recording")
    try:
        data = np.loadtxt(path, delimiter=",", ndmin=2)
    except ValueError as err:
        raise IdentificationInputError(f"{path}: not a numeric comma-separated file ({err})") from None
    if data.shape[1] != 21:
        raise IdentificationInputError(
            f"{path}: expected 21 columns (7 positions, 7 velocities, 7 efforts); got {data.shape[1]}")
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise IdentificationInputError(f"{path}: non-finite value at row {row}, column {col}")
    return WpiRecording(q=data[:, 0:7], dq=data[:, 7:14], tau=data[:, 14:21], source=str(path))
