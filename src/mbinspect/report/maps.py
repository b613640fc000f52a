"""Maps: the plan raster of soundings and what every map carries (north arrow, scale bar,
the CRS named), with matplotlib (Agg)."""

from __future__ import annotations

import io as _io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..grid import bounds as plan_bounds
from ..outputs import atomic_path

__all__ = ["mpl", "save_figure", "plan_image", "map_furniture", "map_figure"]


def mpl() -> Any:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: str | Path, *, tight: bool = True) -> bytes:
    """Save a matplotlib figure as PNG atomically; return the PNG bytes for embedding.

    Parameters
    ----------
    fig : matplotlib Figure
    path : path-like
    tight : bool
        Crop to what is drawn (matplotlib then draws the figure twice); False for a
        figure laid out already (:func:`map_figure`).

    Returns
    -------
    bytes
    """
    buf = _io.BytesIO()
    # zlib level 1: faster to encode than the default 6, the files somewhat larger
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight" if tight else None,
                pil_kwargs={"compress_level": 1})
    mpl().close(fig)
    data = buf.getvalue()
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return data


def plan_image(points: np.ndarray, *, cell: float = 0.25, bounds: Sequence[float] | None = None,
               fill: float = 1.0) -> tuple[np.ndarray, list[float]]:
    """Median elevation per plan cell and its extent for ``imshow``.

    Empty cells within ``fill`` m of a cell with data take its value (gaps between pings);
    farther ones stay NaN.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    cell : float
        Image cell (m).
    bounds : (xmin, ymin, xmax, ymax), optional
    fill : float
        Gap-filling distance (m).

    Returns
    -------
    image : ndarray, shape (ny, nx)
    extent : list of float
        ``[xmin, xmax, ymin, ymax]`` for ``imshow``.
    """
    p = np.asarray(points, np.float64)
    if bounds is None:
        (xmin, ymin), (xmax, ymax) = plan_bounds(p)
    else:
        xmin, ymin, xmax, ymax = bounds
        inside = (p[:, 0] >= xmin) & (p[:, 0] <= xmax) & (p[:, 1] >= ymin) & (p[:, 1] <= ymax)
        p = p[inside]
    nx = max(1, int(math.ceil((xmax - xmin) / cell)))
    ny = max(1, int(math.ceil((ymax - ymin) / cell)))
    i = np.clip(((p[:, 0] - xmin) / cell).astype(np.int64), 0, nx - 1)
    j = np.clip(((p[:, 1] - ymin) / cell).astype(np.int64), 0, ny - 1)
    from scipy import ndimage

    from ..grid import cell_percentile

    img = cell_percentile(j * nx + i, p[:, 2], 50.0, nx * ny).reshape(ny, nx)
    empty = ~np.isfinite(img)
    if fill > 0 and empty.any() and not empty.all():
        # gaps between pings: take the nearest cell with data, up to ``fill`` m away
        dist, idx = ndimage.distance_transform_edt(empty, return_indices=True)
        img = np.where(empty & (dist * cell <= fill), img[tuple(idx)], img)
    return img, [xmin, xmin + nx * cell, ymin, ymin + ny * cell]


def map_figure(extent: Sequence[float], *, width: float = 7.8, colorbar: bool = True) -> tuple[Any, Any, Any]:
    """A plan map's figure laid out for its extent, so that it is drawn once (no tight crop).

    The axes are ``width`` inches wide (narrower for a tall extent, at most 8.5 in high) at
    equal aspect, with room for the tick labels, a title and a colour bar on the right.

    Parameters
    ----------
    extent : (xmin, xmax, ymin, ymax)
    width : float
        The axes' width (in).
    colorbar : bool
        Leave room for and return a colour bar's axes.

    Returns
    -------
    fig, ax, cax : matplotlib Figure, Axes and colour bar Axes (None without one)
    """
    dx, dy = float(extent[1] - extent[0]), float(extent[3] - extent[2])
    aspect = dy / dx if dx > 0 and dy > 0 else 1.0
    aw, ah = width, width * aspect
    if ah > 8.5:
        aw, ah = 8.5 / aspect, 8.5
    ah = max(ah, 2.0)
    left, right, bottom, top = 1.0, (1.3 if colorbar else 0.3), 0.6, 0.45
    fw, fh = left + aw + right, bottom + ah + top
    fig = mpl().figure(figsize=(fw, fh))
    ax = fig.add_axes((left / fw, bottom / fh, aw / fw, ah / fh))
    cax = fig.add_axes(((left + aw + 0.15) / fw, (bottom + 0.15 * ah) / fh, 0.18 / fw, 0.7 * ah / fh)) \
        if colorbar else None
    return fig, ax, cax


def _nice(length: float) -> float:
    """A round length (1, 2 or 5 times a power of ten) not above ``length``."""
    if not length > 0:
        return 1.0
    base = 10.0 ** math.floor(math.log10(length))
    return float(max(m for m in (1.0, 2.0, 5.0) if m * base <= length) * base)


def map_furniture(ax: Any, *, crs_name: str | None, origin: tuple[float, float] | None) -> None:
    """What every map carries: a north arrow, a scale bar, the CRS named and grid coordinates.

    The axes are in metres from ``origin`` (easting, northing in the CRS); the labels say
    so, with the origin's grid coordinates.

    Parameters
    ----------
    ax : matplotlib Axes
        A plan map, equal aspect, in metres east and north of ``origin``.
    crs_name : str or None
        The CRS's name (None: the input's own coordinates).
    origin : (float, float) or None
        Grid coordinates (m) of the axes' zero; None: the axes are grid coordinates.
    """
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    w, h = x1 - x0, y1 - y0
    # north arrow, top right
    ax.annotate("N", xy=(x1 - 0.06 * w, y1 - 0.06 * h), xytext=(x1 - 0.06 * w, y1 - 0.18 * h),
                ha="center", va="center", fontsize=11, weight="bold",
                arrowprops={"arrowstyle": "-|>", "color": "k", "lw": 1.5},
                bbox={"fc": "white", "ec": "none", "alpha": 0.7, "pad": 1})
    # scale bar, bottom left
    bar = _nice(w / 5)
    bx, by = x0 + 0.05 * w, y0 + 0.06 * h
    ax.plot([bx, bx + bar], [by, by], "k-", lw=4, solid_capstyle="butt")
    ax.plot([bx, bx + bar / 2], [by, by], "w-", lw=2, solid_capstyle="butt")
    ax.text(bx + bar / 2, by + 0.025 * h, f"{bar:g} m", ha="center", va="bottom", fontsize=9,
            bbox={"fc": "white", "ec": "none", "alpha": 0.7, "pad": 1})
    if origin is None:
        ax.set_xlabel("easting (m)")
        ax.set_ylabel("northing (m)")
    else:
        ax.set_xlabel(f"easting − {origin[0]:.2f} (m)")
        ax.set_ylabel(f"northing − {origin[1]:.2f} (m)")
    ax.text(0.99, 0.005, crs_name or "the input's own coordinates (no CRS)", transform=ax.transAxes,
            ha="right", va="bottom", fontsize=7, color="0.2",
            bbox={"fc": "white", "ec": "none", "alpha": 0.7, "pad": 1})
