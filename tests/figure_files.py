"""What the figure tests expect: the figures of one drop, and checks that a saved file is a valid PNG
(signature, and matplotlib reads an image of a sensible shape) or PDF (header and end-of-file trailer)."""

from __future__ import annotations

from pathlib import Path

from matplotlib.image import imread

AERO_FIGURES = ("aero_coefficients", "aero_coefficients_alpha_t", "aero_coefficients_sigma")
INPUT_FIGURES = ("inputs_imu", "inputs_gps", "inputs_sounding")
#: Every figure of a per-drop results folder.
DROP_FIGURES = ("altitude_velocity", "qbar_alpha_t", "pitching_moment", "reconciled",
                "residuals_imu", "residuals_gps", "correlation", *AERO_FIGURES, *INPUT_FIGURES)


def assert_png(path: Path) -> None:
    assert path.is_file() and path.stat().st_size > 1000, path
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", path
    image = imread(path)
    assert image.ndim == 3 and image.shape[0] > 300 and image.shape[1] > 300, (path, image.shape)


def assert_pdf(path: Path) -> None:
    data = path.read_bytes()
    assert len(data) > 1000 and data.startswith(b"%PDF-") and data.rstrip().endswith(b"%%EOF"), path


def assert_figure_file(path: Path) -> None:
    """A PNG or PDF file (by suffix) that is valid as above."""
    {".png": assert_png, ".pdf": assert_pdf}[path.suffix](path)
