"""The Python twin of each command (docs/api.md).

Every function accepts a path or an object and returns a typed result
(:mod:`exotune.results`) whose ``to_dict()`` is the command's ``--json`` object, ``to_text()``
its text report and, where the command draws, ``plot(ax=None)`` a matplotlib figure::

    import exotune
    r = exotune.analyze("examples/paper.yaml")
    r.plot()

Errors in the input raise :class:`exotune.errors.ConfigError` (field and reason), as the command
line reports them.
"""

from __future__ import annotations

import os
from dataclasses import replace
from typing import TYPE_CHECKING, Any, Callable, Mapping

from .errors import ConfigError
from .jsonio import check_outputs
from .numerics.engine import numpy_engine
from .options import flag_value, latency_requirement_value, number_value, path_value

if TYPE_CHECKING:  # each function imports what it returns: `exotune analyze` loads no controller-file code
    from .results import (
        Certificate,
        DesignAnalysis,
        DesignSummary,
        ExportedController,
        GeneratedC,
        OptimizeResult,
        PlantEstimate,
        SimulationRun,
        SweepReport,
        SweepResult,
    )

__all__ = ["init", "load_design", "design", "sea", "analyze", "sweep", "report", "optimize", "export", "certify", "codegen",
           "identify", "excite", "simulate"]


def init(directory=".") -> list:
    """Write the commented starting files design.yaml, sweep.yaml and optimize.yaml into
    ``directory`` (the library twin of ``exotune init``; never overwrites: a file already there
    is a :class:`~exotune.errors.ConfigError`). Returns the paths written.

    Parameters
    ----------
    directory : str or os.PathLike, optional
        Where to write the three files (created if missing).

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    ConfigError
        When a file is already there or cannot be written, or ``directory`` is not a path.

    References
    ----------
    docs/getting-started.md.
    """
    from .starter import write_templates

    return list(write_templates(path_value("directory", directory, required=True)))


def load_design(source) -> Any:
    """Read and validate a design.

    Parameters
    ----------
    source : str, os.PathLike, Mapping or DesignConfig
        A design file (YAML, docs/design-file.md), the same content as a mapping, or an already
        loaded design (returned as is).

    Returns
    -------
    DesignConfig
        The validated design: plant, design parameters, implementation, human families,
        environments.

    Raises
    ------
    ConfigError
        The first invalid field and why.

    References
    ----------
    docs/design-file.md; paper §IV (the design parameters).

    Examples
    --------
    >>> cfg = load_design("examples/paper.yaml")
    >>> cfg.design.amplification
    8.0
    """
    from .config import design_from_mapping, load_design as _load

    if isinstance(source, (str, os.PathLike)):
        return _load(source)
    if isinstance(source, Mapping):
        return design_from_mapping(dict(source))
    if hasattr(source, "plant") and hasattr(source, "design"):
        return source
    raise TypeError(f"expected a design file path, a mapping or a DesignConfig, got {type(source).__name__}")


def design(source, *, plots=None) -> DesignSummary:
    """Every controller gain of a design by double compliance shaping, with the nominal transfer
    functions (the library twin of ``exotune design``).

    Parameters
    ----------
    source : path, Mapping or DesignConfig
        See :func:`load_design`.
    plots : path, optional
        Also write the Bode PNGs of C4, C5, Ĉ5, C7 and G_v into this directory (``--plots``).

    Returns
    -------
    DesignSummary
        ``gains`` (torque units, ``units``), ``transfer_functions()`` as python-control objects,
        ``to_dict()`` (= ``exotune design --json``), ``to_text()``, ``plot()``.

    References
    ----------
    Paper §IV, eqs. (16)–(21); docs/method.md#double-compliance-shaping.

    Examples
    --------
    >>> d = design("examples/paper.yaml")
    >>> round(d.gains["K2_hat"], 6), d.units["K1"]
    (7.0, 'N·m/rad')
    """
    from .analysis import design_report

    check_outputs([source], out_dirs={"`plots`": path_value("plots", plots)}, dir_names={"`plots`": ("*.png",)})
    cfg = load_design(source)
    with numpy_engine():
        r = design_report(cfg)
    if plots is not None:
        from .analysis.design_summary import design_bode_figures
        from .jsonio import write_outputs
        from .plots.design import design_plots

        with numpy_engine():
            figures = design_bode_figures(cfg)  # the numbers: the analysis layer's; the plots only draw
        write_outputs(dirs={plots: design_plots(figures)})
    return r


def sea(source) -> Any:
    """A plain SEA compliance-shaping controller analysed (the library twin of ``exotune sea``).

    Parameters
    ----------
    source : str, os.PathLike, Mapping or SeaConfig
        An SEA file: a plant and the four SEA gains (docs/design-file.md#sea-files), the same
        content as a mapping (validated as the file is), or an SEA file already loaded
        (:func:`exotune.config.load_sea`).

    Returns
    -------
    SeaReport
        Its compliances and verdicts; ``to_dict()`` is ``exotune sea --json``.

    Raises
    ------
    ConfigError
        The first invalid field and why.
    TypeError
        When ``source`` is neither a path, a mapping nor a SeaConfig.

    References
    ----------
    Paper §II-B.

    Examples
    --------
    >>> r = sea({"plant": {"motor_inertia": 0.44, "motor_damping": 17.9, "sea_stiffness": 1180.0,
    ...                    "joint_inertia": 0.29},
    ...          "gains": {"units": "deflection", "K1": 69480.0, "B1": 1387.0, "K2": -41690.0, "B2": -1183.0}})
    >>> r.to_dict()["c5_stable"], r.to_dict() == sea("examples/sea.yaml").to_dict() | {"source": None}
    (True, True)
    """
    from .analysis import sea_report
    from .config import SeaConfig, load_sea, sea_from_mapping

    if isinstance(source, SeaConfig):
        cfg = source
    elif isinstance(source, Mapping):
        cfg = sea_from_mapping(dict(source))  # validated as the file is
    elif isinstance(source, (str, os.PathLike)):
        cfg = load_sea(source)
    else:
        raise TypeError(f"expected an SEA file path, a mapping or a SeaConfig, got {type(source).__name__}")
    with numpy_engine():
        return sea_report(cfg)


def analyze(source, *, cross_check: bool = False, plots=None, time_budget_s: float | str | None = None) -> DesignAnalysis:
    """Coupled stability, robust intervals, passivity, DOB margins, amplification and the
    latency margin of one design (the library twin of ``exotune analyze``). With a sample rate,
    the margins and verdicts of record are the sampled-data loop's, as ``certify`` judges the
    exported controller (``r.sampled``; docs/method.md#one-model-of-record).

    Parameters
    ----------
    source : path, Mapping or DesignConfig
        See :func:`load_design`.
    cross_check : bool
        Also compare the exact verdicts with the closed-loop roots of two Padé models.
    plots : path, optional
        Also write the analysis PNGs into this directory (``--plots``; all or none).
    time_budget_s : float, optional
        Stop the analysis beyond this many seconds (default 600; ``--time-budget-s``): with a
        high sample rate the sampled-data verdicts of record can take hours
        (:class:`~exotune.errors.ConfigError` on ``time_budget_s`` then, nothing written).

    Returns
    -------
    DesignAnalysis
        Typed verdicts and metrics; ``to_dict()`` is ``exotune analyze --json``.

    References
    ----------
    Paper §IV-A and Fig. 5; docs/method.md#analyses-and-metrics.

    Examples
    --------
    >>> r = analyze("examples/paper.yaml")
    >>> r.free_stable, r.robust
    (True, False)
    """
    from .controllerfile.verdicts import analyze_of_record

    cross_check = flag_value("cross_check", cross_check)
    check_outputs([source], out_dirs={"`plots`": path_value("plots", plots)}, dir_names={"`plots`": ("*.png",)})
    from .numerics.timebudget import check_budget_option, time_budget

    budget = check_budget_option(time_budget_s)
    cfg = load_design(source)
    fs = cfg.implementation.sample_rate_hz
    what = "analysing the design" + (f" at {fs:g} Hz" if fs else "")
    hint = ("lower `implementation.sample_rate_hz`" if fs else
            "a design this slow has extreme dynamics (a filter cutoff or a plant value decades away from the rest)")
    with numpy_engine(), time_budget(budget, what, hint, writes=plots is not None):
        r = analyze_of_record(cfg)
        if cross_check:
            from .analysis import pade_crosscheck

            r = replace(r, cross_check=pade_crosscheck(cfg))
    if plots is not None:
        from .analysis.figure_data import analysis_figures
        from .jsonio import write_outputs
        from .plots.analysis import write_analysis_plots

        with numpy_engine():
            figs = analysis_figures(cfg, r)  # the numbers: the analysis layer's; the plots only draw
        write_outputs(dirs={plots: lambda tmp: write_analysis_plots(figs, tmp)})
    return r


def sweep(spec, out, *, workers: int | None = None, dask_address: str | None = None, sample: int | None = None,
          seed: int | None = None, chunk_size: int | None = None,
          progress: Callable[[str], None] | None = None) -> SweepResult:
    """Run (or resume) a chunked parameter sweep into ``out`` (the library twin of ``exotune sweep``).

    Parameters
    ----------
    spec : path
        Sweep specification (docs/sweep-spec.md).
    out : path
        Output directory; rerunning with the same spec resumes.
    workers, dask_address, sample, seed, chunk_size
        As the command's options.
    progress : callable, optional
        Receives one line of progress text at a time (nothing is printed otherwise).

    Returns
    -------
    SweepResult
        The manifest and ``table()`` of every row.

    Examples
    --------
    >>> import os, tempfile
    >>> out = os.path.join(tempfile.mkdtemp(), "sweep")
    >>> spec = {"base": "examples/scheduled.yaml",
    ...         "axes": {"design.amplification": [8.0, 20.0], "implementation.delay_s": [0.001, 0.003]}}
    >>> r = sweep(spec, out, workers=1)
    >>> r.status, r.table().num_rows
    ('complete', 4)
    >>> grid, alphas, delays, _, _ = r.map_data("latency_margin_s")   # worst case per (α, T) cell [s]
    >>> bool(grid[0, 0] > grid[1, 0] > 0)     # more delay, less margin left
    True

    References
    ----------
    docs/sweep-spec.md.
    """
    from .config.yamlio import spec_base
    from .sweeps import run_sweep

    check_outputs([spec, spec_base(spec)], out_dirs={"`out`": path_value("out", out, required=True)},
                  dir_names={"`out`": ("manifest.json", "chunks/*")})
    return run_sweep(spec, out, workers=workers, dask_address=dask_address, sample=sample, seed=seed,
                     chunk_size=chunk_size, progress=progress)


def report(sweep_dir, out=None) -> SweepReport:
    """Stability maps and summary tables of a sweep (the library twin of ``exotune report``).

    Parameters
    ----------
    sweep_dir : path or SweepResult
        The sweep directory, or the result of :func:`sweep`.
    out : path, optional
        The report directory (default ``sweep_dir/report``).

    Returns
    -------
    SweepReport
        ``directory`` (the report directory that was written), ``files``, ``maps``; ``to_text()``
        is the line the command prints.

    Examples
    --------
    >>> import os, tempfile
    >>> out = os.path.join(tempfile.mkdtemp(), "sweep")
    >>> _ = sweep({"base": "examples/scheduled.yaml", "axes": {"design.amplification": [4.0, 8.0]}}, out, workers=1)
    >>> from exotune.results import SweepResult
    >>> rep = report(SweepResult.from_directory(out))
    >>> rep.directory.name, (rep.directory / "summary.md").exists(), rep.maps
    ('report', True, ('profile_design.amplification.png',))

    References
    ----------
    docs/sweep-spec.md#report.
    """
    from .plots.sweep_report import make_report
    from .sweeps import SweepResult
    from .sweeps.dataset import check_results_left

    if isinstance(sweep_dir, SweepResult):
        sweep_dir = sweep_dir.directory
    sweep_dir, out = path_value("sweep_dir", sweep_dir, required=True), path_value("out", out)
    check_outputs([sweep_dir, os.path.join(sweep_dir, "manifest.json")], out_dirs={"`out`": out},
                  protected_dirs=[os.path.join(sweep_dir, "chunks")], dir_names={"`out`": ("*.png", "*.md", "*.csv")})
    check_results_left(sweep_dir)  # every chunk file deleted: incomplete, the missing chunks named
    return make_report(sweep_dir, out)


def optimize(spec, out, *, seed: int | None = None, pareto_csv=None) -> OptimizeResult:
    """Maximize the objective under robust-stability constraints and write the best feasible
    design to ``out`` (the library twin of ``exotune optimize``).

    Parameters
    ----------
    spec : str, os.PathLike or Mapping
        The optimization spec (docs/optimize-spec.md): a file or its content.
    out : str or os.PathLike
        Design file to write with the optimum.
    seed : int, optional
        Seed of the search (default: the spec's ``seed``).
    pareto_csv : str or os.PathLike, optional
        Also write the Pareto front (objective against robust fraction) as CSV; ``out`` and it are
        written both or neither.

    Returns
    -------
    OptimizeResult
        The optimum, its feasibility, objective value, binding constraints and metrics.

    Raises
    ------
    ConfigError
        For bad input (before the search: a DOB margin without a DOB, an output that cannot be
        created), an output that would overwrite an input, or one that cannot be written
        (``<path>: cannot write output: <reason>``; nothing is written then).

    Examples
    --------
    >>> import os, tempfile
    >>> out = os.path.join(tempfile.mkdtemp(), "best.yaml")
    >>> spec = {"base": "examples/scheduled.yaml", "free": {"design.amplification": [2.0, 12.0]}, "budget": 50}
    >>> r = optimize(spec, out, seed=0)
    >>> r.feasible, r.objective_value, r.to_dict()["at_bounds"][0]["bound"]   # robust up to the bound
    (True, 12.0, 'upper')

    References
    ----------
    docs/optimize-spec.md.
    """
    from .config.yamlio import spec_base
    from .optimization import run_optimize

    check_outputs([spec, spec_base(spec)], outputs={"`out`": path_value("out", out, required=True),
                                                    "`pareto_csv`": path_value("pareto_csv", pareto_csv)})
    return run_optimize(spec, out, seed=seed, pareto_csv=pareto_csv)


def _rate_override(sample_rate_hz) -> float | None:
    """The ``sample_rate_hz`` keyword (``--sample-rate-hz``) of ``export`` and ``simulate``, which
    replaces a design's ``implementation.sample_rate_hz``: refused, naming the keyword, when it is
    not a positive number or lies outside the design file's accepted range of frequencies.

    Parameters
    ----------
    sample_rate_hz : Any
        The keyword's value (a number, or its text from the command line); None: not given.

    Returns
    -------
    float or None
        The rate [Hz], or None.

    Raises
    ------
    ConfigError
        Field ``sample_rate_hz``: not a positive, finite number, or out of the accepted range
        (docs/design-file.md#input-limits-and-accepted-ranges).
    """
    if sample_rate_hz is None:
        return None
    from .config.validate import check_limit
    from .controllerfile.export import check_sample_rate

    fs = check_sample_rate(sample_rate_hz)
    try:
        return check_limit(fs, "frequency")
    except ValueError as e:  # the range's reason, under the keyword the user gave
        raise ConfigError("sample_rate_hz", str(e)) from None


def export(source, sample_rate_hz: float | None = None, out=None, *, require_latency_margin_s: float | None = None,
           time_budget_s: float | None = None, allow_uncertified: bool = False) -> ExportedController:
    """Export the discrete-time runtime controller of a design file to ``out`` (YAML, written
    atomically; the library twin of ``exotune export``).

    Parameters
    ----------
    source : path or DesignConfig loaded from a file
        The design file (its bytes are hashed into the controller file's provenance).
    sample_rate_hz : float, optional
        Runtime sample rate [Hz] (default: the design's ``implementation.sample_rate_hz``).
    out : path
        Controller file to write (docs/controller-file.md).
    require_latency_margin_s : float, optional
        Latency margin [s] the file must keep (default: the design's ``requirements``, else one
        sample period; 0: none).
    time_budget_s : float, optional
        Seconds after which the export is refused or stopped (default 600).
    allow_uncertified : bool
        Write the file even when it fails its own requirements (else :class:`~exotune.errors.RunFailed`).

    Returns
    -------
    ExportedController
        The controller file's document, its ``path`` and ``summary()``.

    Raises
    ------
    ConfigError
        For a bad design or option, or when the time budget is spent.
    RunFailed
        When the controller would not certify and ``allow_uncertified`` is False.
    TypeError
        When ``source`` is neither a path nor a design loaded from a file, or ``out`` is missing.

    References
    ----------
    docs/controller-file.md; docs/method.md#one-model-of-record; paper §V (the experiments' 1 kHz runtime).

    Examples
    --------
    >>> import os, tempfile
    >>> c = export("examples/scheduled.yaml", 1000.0, os.path.join(tempfile.mkdtemp(), "controller.yaml"))
    >>> c.sample_rate_hz, c.to_dict()["schema"]
    (1000.0, 'exotune.controller/1')
    """
    from .controllerfile import export_design

    path = source if isinstance(source, (str, os.PathLike)) else getattr(source, "source", None)
    if path is None:
        raise TypeError("export needs the design file (a path, or a design loaded from a file)")
    if out is None:
        raise TypeError("export needs out, the controller file to write")
    sample_rate_hz = _rate_override(sample_rate_hz)
    allow_uncertified = flag_value("allow_uncertified", allow_uncertified)
    if require_latency_margin_s is not None:
        require_latency_margin_s = latency_requirement_value("require_latency_margin_s", require_latency_margin_s)
    check_outputs([path], outputs={"`out`": path_value("out", out)})
    if isinstance(source, (str, os.PathLike)):  # an SEA or controller file is named as one, not asked for a rate
        from .config.design import refuse_other_kind
        from .config.yamlio import read_yaml

        refuse_other_kind(read_yaml(source), "design", os.fspath(source))
    with numpy_engine():
        return export_design(path, sample_rate_hz, out, require_latency_margin_s=require_latency_margin_s,
                             time_budget_s=time_budget_s, allow_uncertified=allow_uncertified)


def certify(source, *, precision: str | None = None, time_budget_s: float | str | None = None) -> Certificate:
    """Exact sampled-data certification of a controller file (the library twin of ``exotune certify``).

    Parameters
    ----------
    source : path, Mapping, ControllerFile or ExportedController
        The controller file, its content, the file loaded
        (:func:`exotune.controllerfile.load_controller_file`), or the result of :func:`export`.
    precision : {"float64", "float32"}, optional
        Analyse the file as if exported for this target arithmetic (``certify --precision``;
        docs/controller-file.md#precision); the file is not changed.
    time_budget_s : float, optional
        Refuse or stop the analysis beyond this many seconds (default 600;
        :class:`~exotune.errors.ConfigError` on ``time_budget_s`` then, exit code 2).

    Returns
    -------
    Certificate
        ``certified``, ``reasons`` (every problem when it is not) and the whole report.

    Raises
    ------
    ConfigError
        For an invalid controller file, a controller not built from its design section, or when
        the time budget is spent.
    TypeError
        When ``source`` is neither a path, a mapping, a ControllerFile nor an ExportedController.

    References
    ----------
    docs/controller-file.md#certification.

    Examples
    --------
    >>> import os, tempfile
    >>> c = export("examples/scheduled.yaml", 1000.0, os.path.join(tempfile.mkdtemp(), "c.yaml"))
    >>> cert = certify(c)
    >>> cert.certified, cert.reasons
    (True, ())
    """
    from .controllerfile.certify import certify as _certify
    from .controllerfile import ControllerFile, checked_controller_file, load_controller_file
    from .controllerfile.results import ExportedController

    if isinstance(source, ExportedController):
        source = source.path if source.path is not None else source.to_dict()
    if isinstance(source, ControllerFile):
        source = source.to_dict()  # validated again below, as a mapping is
    if isinstance(source, (str, os.PathLike)):
        doc = load_controller_file(source)
    elif isinstance(source, Mapping):
        doc = checked_controller_file(dict(source))  # validated as a file is
    else:
        raise TypeError("expected a controller file path, a mapping, a ControllerFile or an ExportedController, "
                        f"got {type(source).__name__}")
    from .numerics.timebudget import check_budget_option, time_budget

    name = os.path.basename(source) if isinstance(source, (str, os.PathLike)) else "the controller file"
    with numpy_engine(), time_budget(check_budget_option(time_budget_s), f"certifying {name}", "export at a lower rate",
                                     writes=False):
        return _certify(doc, precision=precision)


def codegen(source, out, *, allow_uncertified: bool = False) -> GeneratedC:
    """The C99 port of a controller file's runtime, with its golden-vector test, written into
    ``out`` (the library twin of ``exotune codegen``).

    Parameters
    ----------
    source : str, os.PathLike or ExportedController
        A controller file, or the result of :func:`export` written to a path; it is certified
        first. Only a file: the generated C is stamped with the sha256 of the file's bytes, which
        a mapping or a loaded ControllerFile does not have (write it first with
        :func:`exotune.controllerfile.write_controller`).
    out : path
        Directory for ``exotune_controller.h``, ``exotune_controller.c`` and
        ``exotune_golden_test.c`` (all written or none).
    allow_uncertified : bool
        Write the C of a file that does not certify (otherwise
        :class:`~exotune.errors.RunFailed`, the reasons named, nothing written); the code says it
        is uncertified.

    Returns
    -------
    GeneratedC
        Where the files went, the number of controllers and sections, the compiler flags, the
        file's sha256 and its certification (``certified``, ``reasons``).

    Raises
    ------
    ConfigError
        ``source``: not a file (a mapping, a ControllerFile, an ExportedController never written,
        another object); an invalid file; a bad ``out`` or ``allow_uncertified``.
    RunFailed
        When the file does not certify and ``allow_uncertified`` is False.

    References
    ----------
    docs/deploying.md; docs/controller-file.md#c-runtime.

    Examples
    --------
    >>> import os, tempfile
    >>> d = tempfile.mkdtemp()
    >>> c = export("examples/scheduled.yaml", 1000.0, os.path.join(d, "c.yaml"))
    >>> g = codegen(c, os.path.join(d, "c_src"))
    >>> g.files[1], g.controllers, g.flags, g.certified
    ('exotune_controller.c', 6, '-std=c99 -O2 -ffp-contract=off', True)
    """
    from .controllerfile import write_c_sources
    from .controllerfile.results import ExportedController

    if isinstance(source, ExportedController):
        if source.path is None:
            raise ConfigError("source", "codegen needs the controller file itself, and this exported controller "
                              "was never written: export it to a path (`out`) first")
        source = source.path
    if not isinstance(source, (str, os.PathLike)):
        what = ("a mapping" if isinstance(source, Mapping) else "a loaded ControllerFile"
                if type(source).__name__ == "ControllerFile" else f"an object of type {type(source).__name__}")
        raise ConfigError("source", f"codegen needs the controller file itself (a path, or an exported controller "
                          f"written to one), got {what}: the generated C is stamped with the sha256 of the file's "
                          "bytes, which only the file has (write it first with "
                          "exotune.controllerfile.write_controller, then pass its path)")
    allow_uncertified = flag_value("allow_uncertified", allow_uncertified)
    check_outputs([source], out_dirs={"`out`": path_value("out", out, required=True)},
                  dir_names={"`out`": ("*.c", "*.h")})
    return write_c_sources(source, out, allow_uncertified=allow_uncertified)


def identify(source, out=None, *, delay_s=0.0, filter_hz: float | None = None,
             sample_rate_hz: float | None = None, friction: bool = False, fix=None, validate=None,
             folds: int | None = None, frf_csv=None, plots=None) -> PlantEstimate:
    """The plant parameters a measured log (or several together) determines, with standard errors
    (the library twin of ``exotune identify``).

    Parameters
    ----------
    source : path or Mapping, or a list of them
        A CSV log (docs/identification.md#the-log), or its columns as a mapping name → sequence;
        a list: several logs identified together (same columns, one rate; paths, or mappings).
    out : path, optional
        Write the ``plant`` and ``uncertainty`` sections (YAML) there (a path source only; only
        when every estimate is physical).
    delay_s : float or "auto"
        Delay [s] from ``tau_cmd`` to the applied torque (logs with ``tau_cmd``); ``"auto"``
        estimates it.
    filter_hz : float, optional
        Corner of the state-variable filter [Hz].
    sample_rate_hz : float, optional
        Sample rate [Hz], overriding the time column (which may then be absent).
    friction : bool
        Estimate Coulomb friction F_c·sign(θ̇_m) in the motor equation (the paper's δ_f).
    fix : mapping or iterable of "NAME=VALUE", optional
        Known parameters (design-file keys or symbols, SI units).
    validate : path, optional
        A second log to validate on (a path source only).
    folds : int, optional
        K-fold cross-validation on the log itself (a path source only).
    frf_csv : path, optional
        Also write the measured frequency responses there (CSV; ``--frf-csv``).
    plots : path, optional
        Also write the Bode overlays, residual tests (PNG) and ``frequency_response.csv`` into
        this directory (``--plots``).

    Returns
    -------
    PlantEstimate
        ``parameters`` (value, standard error, unit), ``fits``, ``validation`` (for a path
        source), ``uncertainty()``, ``design_sections()``.

    Raises
    ------
    ConfigError
        Bad input, naming the keyword (or the log's column, row or file) and the reason: no log,
        a source that is neither a path nor a mapping, a keyword that is not a number (numpy
        scalars are numbers; text is not), ``folds`` not a whole number ≥ 2, an estimate outside
        the design file's accepted range, an output that cannot be written (then none is).

    References
    ----------
    docs/identification.md; paper eq. (5).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(2000) / 1000.0                      # 2 s at 1 kHz
    >>> th = 0.01 * np.sin(2 * np.pi * 3 * t) + 0.004 * np.sin(2 * np.pi * 17 * t + 1)   # motor angle [rad]
    >>> w = 2 * np.pi * np.array([3.0, 17.0])
    >>> thd = 0.01 * w[0] * np.cos(w[0] * t) + 0.004 * w[1] * np.cos(w[1] * t + 1)
    >>> thdd = -0.01 * w[0] ** 2 * np.sin(w[0] * t) - 0.004 * w[1] ** 2 * np.sin(w[1] * t + 1)
    >>> tau_s = np.zeros_like(t)                          # SEA unloaded: τ_m drives J_m, B_m alone
    >>> r = identify({"t": t, "theta_m": th, "tau_s": tau_s, "tau_m": 0.44 * thdd + 17.9 * thd})
    >>> round(r["motor_inertia"].value, 3), round(r["motor_damping"].value, 2), r["motor_inertia"].unit
    (0.44, 17.9, 'kg·m²')
    """
    from .identification import identify_file, identify_plant, log_from_columns
    from .identification.estimate import parse_fix

    friction, fix = flag_value("friction", friction), parse_fix(fix)  # bad keywords before any log is read
    for name, p in (("out", out), ("validate", validate), ("frf_csv", frf_csv), ("plots", plots)):
        path_value(name, p)
    if filter_hz is not None:
        filter_hz = number_value("filter_hz", filter_hz, positive=True, noun="a filter corner [Hz]", strings=False)
    if sample_rate_hz is not None:
        sample_rate_hz = number_value("sample_rate_hz", sample_rate_hz, positive=True, noun="a sample rate [Hz]",
                                      strings=False)
    if folds is not None:
        from .identification.validate import check_folds

        folds = check_folds(folds)
    several = isinstance(source, (list, tuple))
    if several and not source:
        raise ConfigError("source", "no log given: a path or a mapping of columns, or a non-empty list of them")
    if not several and not isinstance(source, (str, os.PathLike, Mapping)):
        raise ConfigError("source", f"expected a log (a path or a mapping of columns) or a list of them, got "
                          f"{type(source).__name__} {source!r}"[:200])
    if several and not all(isinstance(x, (str, os.PathLike, Mapping)) for x in source):
        bad = next(x for x in source if not isinstance(x, (str, os.PathLike, Mapping)))
        raise ConfigError("source", f"expected logs (paths or mappings of columns), got {type(bad).__name__} "
                          f"{bad!r}"[:200])
    if isinstance(source, Mapping) or (several and all(isinstance(x, Mapping) for x in source)):
        given = [k for k, x in (("out", out), ("validate", validate), ("folds", folds), ("frf_csv", frf_csv),
                                ("plots", plots)) if x is not None]
        if given:
            raise ConfigError(given[0], "identify writes its sections and validates only for a log file (give a path)")
        maps = list(source) if several else [source]
        logs = [log_from_columns(dict(m), f"<mapping {i + 1}>" if several else "<mapping>", delay_s, sample_rate_hz)
                for i, m in enumerate(maps)]
        return identify_plant(logs if several else logs[0], filter_hz=filter_hz, friction=friction, fix=fix)
    check_outputs([*(source if several else [source]), validate], outputs={"`out`": out, "`frf_csv`": frf_csv},
                  out_dirs={"`plots`": plots}, dir_names={"`plots`": ("*.png", "*.csv")})
    if several and any(isinstance(x, Mapping) for x in source):
        raise ConfigError("source", "give paths or mappings of columns, not both")
    return identify_file(source, out, delay_s=delay_s, filter_hz=filter_hz, sample_rate_hz=sample_rate_hz,
                         friction=friction, fix=fix, validate=validate, folds=folds, frf_csv=frf_csv, plots=plots)


def excite(out=None, *, sample_rate_hz: float, f_lo_hz: float, f_hi_hz: float, peak_nm: float | None = None,
           rms_nm: float | None = None, period_s: float | None = None, periods: int | None = None,
           duration_s: float | None = None, lines: str = "all", seed: int | None = None):
    """A Schroeder-phased multisine command for an identification experiment (the library twin of
    ``exotune excite``): the keywords are the command's options, checked and computed by
    :func:`exotune.identification.schroeder_multisine` (band 0 < f_lo_hz < f_hi_hz <
    sample_rate_hz/2 [Hz], amplitude as ``peak_nm`` or ``rms_nm`` [N·m], ``period_s`` (default
    1/f_lo), ``periods`` or ``duration_s``, ``lines`` all/odd/random-odd/log, ``seed``). With
    ``out``, the command is written there as CSV (``t`` [s], ``tau_cmd`` [N·m], the log format
    ``identify`` reads) and described beside it (``EXC.json``: units, lines, phases, crest factor).

    Parameters
    ----------
    out : str or os.PathLike, optional
        CSV file to write (its sidecar ``EXC.json`` beside it); None to write nothing.
    sample_rate_hz : float
        Sample rate [Hz] of the command.
    f_lo_hz, f_hi_hz : float
        The excited band [Hz].
    peak_nm : float, optional
        Peak of the command [N·m] (give this or ``rms_nm``).
    rms_nm : float, optional
        RMS of the command [N·m].
    period_s : float, optional
        Period of the multisine [s] (default 1/f_lo_hz).
    periods : int, optional
        Number of periods (give this or ``duration_s``).
    duration_s : float, optional
        Length of the command [s].
    lines : str, optional
        Which lines of the band are excited: ``all``, ``odd``, ``random-odd`` or ``log``.
    seed : int, optional
        Seed of the ``random-odd`` selection.

    Returns
    -------
    Excitation
        ``period`` (one period of the command, N·m), ``signal()`` (t, tau_cmd), ``harmonics``,
        ``phases_rad``, ``crest_factor``, ``resolution_hz``, ``to_csv()``.

    Raises
    ------
    ConfigError
        For an invalid option or an unwritable output.

    References
    ----------
    docs/identification.md#excite.

    Examples
    --------
    >>> e = excite(sample_rate_hz=1000.0, f_lo_hz=1.0, f_hi_hz=20.0, rms_nm=1.0, periods=2)
    >>> len(e.harmonics), e.resolution_hz, round(e.rms_nm, 12), round(e.crest_factor, 2)
    (20, 1.0, 1.0, 1.76)
    """
    from .identification import schroeder_multisine, write_excitation

    from .identification.excite import sidecar_path

    if path_value("out", out) is not None:
        check_outputs([], outputs={"`out`": out, "`out` (its sidecar)": sidecar_path(out)})
    e = schroeder_multisine(sample_rate_hz, f_lo_hz, f_hi_hz, peak_nm=peak_nm, rms_nm=rms_nm, period_s=period_s,
                            periods=periods, duration_s=duration_s, lines=lines, seed=seed)
    return e if out is None else write_excitation(e, out)


def simulate(source, scenario: str, *, sample_rate_hz: float | None = None,
             human_inertia: float | None = None, duration: float | None = None, start: str = "bumpless",
             joint_angle: float | None = None, plots=None,
             progress: Callable[[float], None] | None = None,
             time_budget_s: float | str | None = None) -> SimulationRun:
    """Time-domain run of the runtime controller on the plant (the library twin of
    ``exotune simulate``).

    Parameters
    ----------
    source : path, Mapping, DesignConfig, ControllerFile or ExportedController
        A design file (with ``sample_rate_hz``) or a controller file, the same content as a
        mapping (validated as the file is), a loaded design, a loaded controller file, or the
        result of :func:`export`.
    scenario : str
        ``locked-output``, ``dob-friction``, ``light-mass``, ``saturation`` or ``backlash``.
    sample_rate_hz : float, optional
        Sample rate [Hz] for a design (default: its ``implementation.sample_rate_hz``).
    human_inertia : float, optional
        Human inertia [kg·m²] instead of the scenario's (``--human-inertia``).
    duration : float, optional
        Run length [s] instead of the scenario's (``--duration``).
    start : {"bumpless", "zero"}
        Initial controller state (``--start``).
    joint_angle : float, optional
        Run the gain-schedule entry nearest this joint angle [rad] (``--joint-angle``), as the
        runtime picks it; an angle outside the schedule's angles is refused (the file describes no
        plant there). The result names the entry that ran (``gain_schedule_entry``).
    plots : path, optional
        Also write the time-series PNGs into this directory (``--plots``).
    progress : callable, optional
        Called with the completed fraction (0–1) of the main run.
    time_budget_s : float, optional
        Stop the simulation beyond this many seconds (default 600; ``--time-budget-s``):
        :class:`~exotune.errors.ConfigError` on ``time_budget_s`` then, naming the runs finished
        and where the current one stopped; nothing written.

    Returns
    -------
    SimulationRun
        The run: its verdict, summary and time series; ``plot()`` draws them.

    Raises
    ------
    ConfigError
        For bad input (a file, the scenario, an option, a joint angle outside the gain schedule,
        runs longer together than the scenario's sample limit: ``duration``, before any run), an
        output that would overwrite an input, or a spent time budget (``time_budget_s``).
    TypeError
        When ``source`` is none of the kinds above, or ``progress`` is neither callable nor None.

    References
    ----------
    docs/cli.md#simulate; paper §V (experiments).

    Examples
    --------
    >>> run = simulate("examples/scheduled.yaml", "locked-output")
    >>> s = run.to_dict()["summary"]
    >>> s["verdict"], round(s["delivered_amplification"]["value"], 4)
    ('decaying', 8.0)
    """
    from .controllerfile import ControllerFile
    from .controllerfile.results import ExportedController
    from .simulation import load_for_simulation, run_scenario
    from .simulation.load import check_joint_angle
    from .simulation.report import check_run_options
    from .numerics.timebudget import check_budget_option, time_budget

    if isinstance(source, ExportedController):
        source = source.path if source.path is not None else source.to_dict()
    if isinstance(source, ControllerFile):
        source = source.to_dict()  # validated again, as a mapping is
    if not (isinstance(source, (str, os.PathLike, Mapping)) or (hasattr(source, "raw") and hasattr(source, "plant"))):
        raise TypeError("expected a design or controller file path, a mapping, a DesignConfig, a ControllerFile or "
                        f"an ExportedController, got {type(source).__name__}")
    if progress is not None and not callable(progress):
        raise TypeError("progress must be a function of the completed fraction (0–1) or None; got "
                        f"{type(progress).__name__}")
    check_outputs([source], out_dirs={"`plots`": path_value("plots", plots)}, dir_names={"`plots`": ("*.png",)})
    check_run_options(scenario, start, human_inertia, duration)  # bad options before the file is loaded
    check_joint_angle(joint_angle)
    fs = _rate_override(sample_rate_hz)
    budget = check_budget_option(time_budget_s)
    with numpy_engine(), time_budget(budget, f"simulating scenario {getattr(scenario, 'name', scenario)}", "shorten `duration` or lower the rate",
                                     writes=plots is not None):
        doc = load_for_simulation(source, fs)
        r = run_scenario(doc, scenario, human_inertia=human_inertia, duration_s=duration, start=start,
                         progress=progress, joint_angle=joint_angle)
    if plots is not None:
        from .jsonio import write_outputs
        from .plots.simulate import plot_simulation

        write_outputs(dirs={plots: plot_simulation(r.plot_report())})  # long runs thinned for drawing
    return r
