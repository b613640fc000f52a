""":func:`simulate` (one survey in memory) and :func:`simulate_lines` (one file per line,
streamed)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import integer, positive
from ..errors import ParameterError
from ..io import PointCloud, write
from .builders import build_jacket, build_reef_field, build_wharf
from .presets import (
    options_class,
)
from .scene import LABELS, Scene
from .sonar import DEFAULT_SONAR, Line, Sonar, Survey, named_sonar
from .survey import line_times, survey
from .truth import reef_reference_rows, scene_truth


@dataclass(frozen=True, eq=False)
class Simulation:
    """A simulated survey: the soundings, what each one hit, and the exact truth.

    Attributes
    ----------
    cloud : PointCloud
    labels, ident : ndarray
        Per-sounding truth (see :func:`survey`).
    truth : dict
        JSON-ready truth: piles and spacings, reefs and groups, distractors, seabed.
    scene : Scene
    plan : Survey
    """

    cloud: PointCloud
    labels: np.ndarray
    ident: np.ndarray
    truth: dict[str, Any]
    scene: Scene
    plan: Survey

    def reference_rows(self, *, sigma: float = 0.15, seed: int = 0) -> list[tuple[float, float, int]]:
        """Reef positions as a surveyor would digitise them (x, y, id), with ``sigma`` m scatter."""
        return reef_reference_rows(self.truth, sigma=sigma, seed=seed)


#: Most soundings a simulation makes unless ``force`` (about 5 GB of memory at this size).
MAX_SOUNDINGS = 50_000_000




def simulate(preset: str, *, seed: int = 0, progress: Callable[[float], None] | None = None,
             force: bool = False, survey_lines: Sequence[Sequence[Sequence[float]]] | None = None,
             survey_speed: float | None = None, **overrides: Any) -> Simulation:
    """Simulate a preset survey with exact truth.

    Parameters
    ----------
    preset : {"jacket", "reef-field"}
    seed : int
        Seeds the scene (as-built deviations, reef placement) and, independently,
        the measurement errors. The same seed gives the same soundings and truth.
    progress : callable, optional
        Called with the fraction of pings done.
    force : bool
        Simulate even when the survey would make more than :data:`MAX_SOUNDINGS`.
    survey_lines : sequence of ((x, y), (x, y)), optional
        Lines to sail instead of the preset's, each from its start to its end in the scene's
        world coordinates (a plan's ``lines.csv``), at the preset's ``ping_spacing``.
    survey_speed : float, optional
        The speed (m/s) ``survey_lines`` are sailed at (the plan's; by default the lines'
        2 m/s): the vessel's roll, pitch and heave run in time, so the same pings at another
        speed meet the structure in another phase of its motion.
    **overrides
        Any field of the preset's options (:class:`JacketOptions`,
        :class:`ReefFieldOptions`) or of :class:`Sonar`.

    Returns
    -------
    Simulation

    Raises
    ------
    ParameterError
        An unknown or bad option (named by its library name), a negative seed, or a survey
        of more than :data:`MAX_SOUNDINGS` without ``force``.

    Examples
    --------
    >>> sim = simulate("jacket", seed=1, ping_spacing=1.0)
    >>> len(sim.truth["piles"]), sim.truth["spacings"][0]["a"]
    (4, 1)
    """
    setup = _setup(preset, seed, overrides)
    if survey_lines is not None:
        setup = dataclasses.replace(setup, plan=_resailed(setup, survey_lines, survey_speed))
    estimate = setup.plan.estimated_soundings()
    if estimate > MAX_SOUNDINGS and not force:
        raise ParameterError(
            f"ping_spacing: {setup.opt.ping_spacing} m makes about {estimate / 1e6:,.0f} million soundings; "
            f"expected at most {MAX_SOUNDINGS / 1e6:,.0f} million (give `force` to simulate it anyway)",
            option="ping_spacing")
    cloud, labels, ident = survey(setup.scene, setup.plan, seed=int(setup.noise_seed.generate_state(1)[0]),
                                  progress=progress)
    truth = scene_truth(preset, seed, setup.opt, setup.sonar, setup.scene, labels, setup.extra)
    truth["sonar"] = {"name": setup.sonar_name, **truth["sonar"]}
    if (setup.sonar.tide_range or setup.sonar.tide_mean) and len(cloud):
        truth["tide"] = tide_rows(setup.sonar, cloud.fields["time"])
    return Simulation(cloud, labels, ident, truth, setup.scene, setup.plan)


#: The step (s) of a simulated tide series, and how far it reaches beyond the survey.
TIDE_STEP_S, TIDE_MARGIN_S = 600.0, 3600.0


def tide_rows(sonar: Sonar, times: np.ndarray) -> list[dict[str, Any]]:
    """The sonar's tide as a gauge would record it: ``time`` (UTC, ISO 8601) and ``height``
    (m above chart datum) every :data:`TIDE_STEP_S` over the survey and an hour each side."""
    import datetime as dt

    t0 = math.floor((float(times.min()) - TIDE_MARGIN_S) / TIDE_STEP_S) * TIDE_STEP_S
    t = np.arange(t0, float(times.max()) + TIDE_MARGIN_S + TIDE_STEP_S, TIDE_STEP_S)
    return [{"time": dt.datetime.fromtimestamp(float(v), dt.UTC).isoformat().replace("+00:00", "Z"),
             "height": round(float(h), 4)} for v, h in zip(t, sonar.tide(t), strict=True)]


def _resailed(setup: _Setup, lines: Sequence[Sequence[Sequence[float]]], speed: float | None = None
              ) -> Survey:
    """The setup's survey with ``lines`` (world coordinates) instead of the preset's, at
    ``speed`` (m/s) when given."""
    ox, oy = setup.scene.origin
    spacing = setup.plan.lines[0].ping_spacing if setup.plan.lines else 0.1
    out = []
    for k, line in enumerate(lines):
        v = [(float(x) - ox, float(y) - oy) for x, y in line]
        if len(v) < 2 or not all(math.isfinite(c) for p in v for c in p):
            raise ParameterError(f"survey_lines: line {k + 1} is {line!r}; expected a start and an end, "
                                 "each x, y", option="survey_lines")
        out.append(Line(tuple(v), ping_spacing=spacing) if speed is None else
                   Line(tuple(v), ping_spacing=spacing, speed=positive("survey_speed", speed)))
    if not out:
        raise ParameterError("survey_lines: no line given; expected at least one", option="survey_lines")
    return Survey(tuple(out), setup.plan.sonar)


@dataclass(frozen=True)
class _Setup:
    opt: Any
    sonar: Sonar
    sonar_name: str
    scene: Scene
    plan: Survey
    extra: dict[str, Any]
    noise_seed: np.random.SeedSequence


def _setup(preset: str, seed: int, overrides: dict[str, Any]) -> _Setup:
    """The preset's options checked, its scene built and its lines planned."""
    integer("seed", seed, minimum=0, maximum=2**63 - 1)
    opt_cls = options_class(preset)
    overrides = dict(overrides)
    sonar_name = overrides.pop("sonar", DEFAULT_SONAR)
    sonar = named_sonar(sonar_name)
    opt_fields = {f.name for f in dataclasses.fields(opt_cls)}
    sonar_fields = {f.name for f in dataclasses.fields(Sonar)}
    unknown = set(overrides) - opt_fields - sonar_fields
    if unknown:
        raise ParameterError(
            f"{sorted(unknown)[0]}: not an option of the {preset} preset; "
            f"expected one of {', '.join(sorted(opt_fields | sonar_fields | {'sonar'}))}",
            option=sorted(unknown)[0]
        )
    opt = opt_cls(**{k: v for k, v in overrides.items() if k in opt_fields})
    sonar = dataclasses.replace(sonar, **{k: v for k, v in overrides.items() if k in sonar_fields})
    scene_seed, noise_seed = np.random.SeedSequence(seed).spawn(2)
    builders: dict[str, Callable[..., tuple[Scene, Survey, dict[str, Any]]]] = {
        "jacket": build_jacket, "wharf": build_wharf, "reef-field": build_reef_field}
    scene, plan, extra = builders[preset](opt, np.random.default_rng(scene_seed), sonar)
    return _Setup(opt, sonar, sonar_name, scene, plan, extra, noise_seed)


def simulate_lines(preset: str, out: str | Path, *, seed: int = 0, suffix: str = ".laz",
                   progress: Callable[[float], None] | None = None, workers: int = 1,
                   **overrides: Any) -> dict[str, Any]:
    """Simulate a preset survey as one file per line, streaming line by line: memory
    follows one line, not the survey (no :data:`MAX_SOUNDINGS` limit).

    Each line is sailed on its own (its errors drawn from its own seed, spawned from
    ``seed``) over the objects within reach of its swath; ``line_NNN<suffix>`` holds its
    soundings (fields ``intensity``, ``beam_angle``, ``line``, ``ping`` from 1 per line,
    ``label``), and ``truth.json`` the truth as :func:`simulate` writes it. The files do
    not depend on ``workers``.

    Parameters
    ----------
    preset : {"jacket", "wharf", "reef-field"}
    out : path-like
        A folder (created).
    seed : int
    suffix : str
        The files' format, by extension (``.laz``, ``.las``, ``.npz``, ``.xyz``).
    progress : callable, optional
        Called with the fraction of lines written.
    workers : int
        Lines simulated at once, in as many processes.
    **overrides
        As :func:`simulate`.

    Returns
    -------
    dict
        The truth (also in ``truth.json``), with ``files``.
    """
    from concurrent.futures import ProcessPoolExecutor

    from ..outputs import write_json

    setup = _setup(preset, seed, overrides)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    n = len(setup.plan.lines)
    jobs = [(preset, seed, tuple(sorted(overrides.items())), k, str(folder), suffix) for k in range(n)]
    counts: dict[str, int] = {}
    files = []
    total = 0
    if workers > 1:
        with ProcessPoolExecutor(workers) as pool:
            done = pool.map(_line_job, jobs)
            results = []
            for k, r in enumerate(done):
                results.append(r)
                if progress is not None:
                    progress((k + 1) / n)
    else:
        results = []
        for k, job in enumerate(jobs):
            results.append(_line_job(job, setup))
            if progress is not None:
                progress((k + 1) / n)
    for name, line_counts in results:
        files.append(name)
        for label, c in line_counts.items():
            counts[label] = counts.get(label, 0) + c
            total += c
    truth = scene_truth(preset, seed, setup.opt, setup.sonar, setup.scene, np.zeros(0, np.int8), setup.extra)
    truth.update(sonar={"name": setup.sonar_name, **truth["sonar"]}, counts=counts, n_soundings=total,
                 files=files)
    if setup.sonar.tide_range or setup.sonar.tide_mean:
        truth["tide"] = tide_rows(setup.sonar, np.array(line_times(setup.plan)).ravel())
    write_json(truth, folder / "truth.json")
    return truth


#: The scene a worker process of :func:`simulate_lines` last built, by its job's preset,
#: seed and options.
_SETUPS: dict[tuple[Any, ...], _Setup] = {}


def _line_job(job: tuple[str, int, tuple[tuple[str, Any], ...], int, str, str], setup: _Setup | None = None
              ) -> tuple[str, dict[str, int]]:
    """Sail line ``k`` of a preset and write its file; its name and label counts."""
    preset, seed, overrides, k, folder, suffix = job
    if setup is None:  # in a worker process: build the scene once for all its lines
        key = (preset, seed, overrides)
        if key not in _SETUPS:
            _SETUPS.clear()
            _SETUPS[key] = _setup(preset, seed, dict(overrides))
        setup = _SETUPS[key]
    line = setup.plan.lines[k]
    sonar = setup.sonar
    line_seed = setup.noise_seed.spawn(len(setup.plan.lines))[k]
    reach = (sonar.draft + abs(float(setup.scene.seabed.z0)) + 15.0) * math.tan(
        math.radians(min(sonar.swath_deg, 170.0) / 2)) + 10.0
    v = np.asarray(line.vertices, np.float64)
    box = (v[:, 0].min() - reach, v[:, 0].max() + reach, v[:, 1].min() - reach, v[:, 1].max() + reach)
    # the line sailed when it would be in the whole survey (its tide, its time stamps)
    sonar = dataclasses.replace(sonar, start_time=line_times(setup.plan)[k][0])
    cloud, labels, _ = survey(_near(setup.scene, box), Survey((line,), sonar),
                              seed=int(line_seed.generate_state(1)[0]))
    fields = {**cloud.fields, "line": np.full(len(cloud), k + 1, np.int32), "label": labels.astype(np.int32)}
    name = Path(folder) / f"line_{k + 1:03d}{suffix}"
    write(PointCloud(cloud.xyz, fields), name)
    return name.name, {label: int(np.sum(labels == code)) for label, code in LABELS.items()}


def _near(scene: Scene, box: tuple[float, float, float, float]) -> Scene:
    """The scene with only the objects whose plan extent meets ``box`` (local metres)."""
    x0, x1, y0, y1 = box

    def meets(b: tuple[float, float, float, float]) -> bool:
        return not (b[1] < x0 or b[0] > x1 or b[3] < y0 or b[2] > y1)

    piles = tuple(p for p in scene.piles if meets((p.x - 5, p.x + 5, p.y - 5, p.y + 5)))
    reefs = tuple(r for r in scene.reefs if meets((r.x - 10, r.x + 10, r.y - 10, r.y + 10)))
    boulders = tuple(b for b in scene.boulders if meets((b.x - 5, b.x + 5, b.y - 5, b.y + 5)))
    debris = tuple(d for d in scene.debris if meets((d.cx - 5, d.cx + 5, d.cy - 5, d.cy + 5)))
    return dataclasses.replace(scene, piles=piles, reefs=reefs, boulders=boulders, debris=debris)
