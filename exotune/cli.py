"""The ``exotune`` command line: a thin layer over the library.

Each command parses its arguments, makes one library call (:mod:`exotune.analysis`,
:mod:`exotune.sweeps`, :mod:`exotune.optimization`, :mod:`exotune.controllerfile`,
:mod:`exotune.simulation`), formats the result (:mod:`exotune.text`, or strict JSON with
:func:`exotune.jsonio.dumps`), writes the requested files (:mod:`exotune.plots`, written by
:func:`exotune.jsonio.write_outputs`) and maps the outcome to an exit code. Library modules are
imported lazily, so ``exotune --help`` stays fast.

Error contract: every input problem (an :class:`~exotune.errors.ExotuneError` such as
:class:`~exotune.errors.ConfigError`, a :class:`ValueError`, an unwritable output, or a bad
command line: unknown command or option, missing or invalid option value) is printed as one line
``exotune: error: <field or option>: <reason>`` on stderr, without a traceback, with exit code 2
(or the error's own ``exit_code``). Outputs (plots) are produced completely before anything is
written, and each file is written atomically, so a failing run leaves nothing behind.
"""

from __future__ import annotations

import os

import click
from click.core import ParameterSource

from .version import __version__
from .errors import ExotuneError

__all__ = ["main", "cli"]


# ---------------------------------------------------------------------------------------------
# click plumbing
# ---------------------------------------------------------------------------------------------
class InputError(click.ClickException):
    """Bad input: printed as one line ``exotune: error: …``, exit code 2 (or ``exit_code``)."""

    exit_code = 2

    def __init__(self, message: str, exit_code: int | None = None, more=()):
        from .errors import MAX_MORE_LINES

        super().__init__(message)
        if exit_code is not None:
            self.exit_code = exit_code
        more = list(more)
        if len(more) >= MAX_MORE_LINES:  # the first MAX_MORE_LINES problems, then how many more
            rest = len(more) - (MAX_MORE_LINES - 1)
            more = more[:MAX_MORE_LINES - 1] + [f"… and {rest:,} more problems".replace(",", " ")]
        self.more = more

    def show(self, file=None) -> None:
        from .errors import printable

        # a key or path of the user's may hold terminal escapes: shown escaped, never acted on
        click.echo(printable(f"exotune: error: {self.format_message()}"), err=True)
        for line in self.more:  # the file's further errors, one per line
            click.echo(printable(line), err=True)


def _echo(text: str) -> None:
    """Print a report on stdout: the control characters of the user's strings it quotes (a file
    name, a design's or requirement's text) shown escaped, never sent to the terminal as they are
    (an ESC starting an ANSI or OSC sequence); line breaks and tabs kept. JSON is already escaped
    (:func:`exotune.jsonio.dumps`)."""
    from .errors import printable

    click.echo(printable(text, keep="\n\t"))


def _usage_line(e: click.UsageError) -> str:
    """``<option or argument>: <reason>`` for a click usage error (one line, the parameter named)."""
    name, reason = None, e.message
    if isinstance(e, click.BadParameter):
        p = e.param
        if isinstance(e.param_hint, str):
            name = e.param_hint
        elif e.param_hint:
            name = " / ".join(e.param_hint)
        elif isinstance(p, click.Option):
            name = max(p.opts, key=len)
        elif p is not None:
            name = p.human_readable_name
        if isinstance(e, click.MissingParameter) and not reason:
            kind = e.param_type or (p.param_type_name if p is not None else "parameter")
            reason = f"missing required {kind}"
    elif isinstance(e, click.NoSuchOption):
        name, reason = e.option_name, "no such option"
        if e.possibilities:
            reason += " (did you mean " + ", ".join(sorted(e.possibilities)) + "?)"
    elif isinstance(e, click.BadOptionUsage):
        name = e.option_name
    if name is None:
        name = e.ctx.command_path if e.ctx is not None else "exotune"
    import re

    # click quotes the value as given: a 5 000-character argument is cut to an excerpt
    reason = re.sub(r"\S{81,}", lambda m: f"{m.group(0)[:60]}… ({len(m.group(0))} characters)", str(reason))
    return f"{name}: {' '.join(reason.split())}"


def _as_flags(flags: dict, text: str) -> str:
    """``text`` with every backticked keyword of ``flags`` replaced by its option."""
    import re

    return re.sub(r"`([A-Za-z_][A-Za-z0-9_]*)`", lambda m: flags.get(m.group(1), m.group(0)), text)


#: ``ctx.meta`` key of the invoked command's context (its parameters' sources name the options given)
_SUB_CONTEXT = "exotune.command_context"


class _Command(click.Command):
    """An ``exotune`` command: its context is kept in the shared ``ctx.meta`` so that the group can
    tell, when a library error comes back, which options the user gave."""

    def make_context(self, info_name, args, parent=None, **extra):
        ctx = super().make_context(info_name, args, parent=parent, **extra)
        ctx.meta[_SUB_CONTEXT] = ctx
        return ctx


def _typed_elsewhere(ctx, field: str) -> bool:
    """Whether ``field`` is what the user typed as the value of a parameter other than the option
    ``field`` names (a path that happens to be spelt like a keyword)."""
    sub = ctx.meta.get(_SUB_CONTEXT)
    if sub is None:
        return False
    for name, value in sub.params.items():
        if name == field or sub.get_parameter_source(name) != ParameterSource.COMMANDLINE:
            continue
        values = value if isinstance(value, (list, tuple)) else (value,)
        if any(isinstance(v, (str, os.PathLike)) and os.fspath(v) == field for v in values):
            return True
    return False


class _Group(click.Group):
    """The ``exotune`` group: maps library errors and click usage errors to one-line errors."""

    command_class = _Command

    def make_context(self, info_name, args, parent=None, **extra):
        try:
            return super().make_context(info_name, args, parent=parent, **extra)
        except click.exceptions.NoArgsIsHelpError:
            raise
        except click.UsageError as e:
            raise InputError(_usage_line(e), e.exit_code) from None

    def resolve_command(self, ctx, args):
        try:
            return super().resolve_command(ctx, args)
        except click.NoSuchOption:
            raise
        except click.UsageError:
            raise InputError(f"{args[0]}: no such command (commands: {', '.join(self.list_commands(ctx))})") from None

    def _flags(self, ctx) -> dict:
        """Keyword of the API call → the invoked command's option that feeds it (``human_inertia``
        → ``--human-inertia``)."""
        cmd = self.get_command(ctx, ctx.invoked_subcommand) if ctx.invoked_subcommand else None
        return {p.name: p.opts[0] for p in getattr(cmd, "params", ()) if isinstance(p, click.Option)}

    def _option_named(self, ctx, flags: dict, e) -> str:
        """The error's line in the command line's words: a field that is the keyword of an option
        is named as that option — unless it is a key of an input file (``in_file``) or the value
        the user gave another parameter (``exotune report out``: the directory ``out``, not
        ``-o``) — and so is a keyword the reason quotes in backticks (the library speaks of its
        keywords: "give `periods` or `duration_s`, not both")."""
        field = getattr(e, "field", None)
        keyword = field in flags and not getattr(e, "in_file", False) and not _typed_elsewhere(ctx, field)
        text = f"{flags[field]}: {e.reason}" if keyword else str(e)
        return _as_flags(flags, text)

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except click.exceptions.NoArgsIsHelpError:
            raise
        except click.UsageError as e:
            raise InputError(_usage_line(e), e.exit_code) from None
        except ExotuneError as e:
            flags = self._flags(ctx)
            raise InputError(self._option_named(ctx, flags, e), e.exit_code,
                             [_as_flags(flags, m) for m in getattr(e, "more", ())]) from None
        except ValueError as e:
            raise InputError(" ".join(str(e).split()) or type(e).__name__) from None
        except OSError as e:  # an unwritable output (a directory, a missing parent, no permission)
            where = e.filename2 if e.filename2 is not None else (e.filename if e.filename is not None else "<file>")
            raise InputError(f"{where}: {e.strerror or e}") from None


class _Int(click.IntRange):
    """An integer option: decimal digits as a YAML file writes an integer (``1_000``, ``1e3``,
    non-ASCII digits are refused, naming the option, though Python's ``int`` reads some), within
    the range given (click's range message)."""

    def convert(self, value, param, ctx):
        from .options import INTEGER_TEXT

        shown = repr(value) if not isinstance(value, str) or len(value) <= 40 else \
            f"{value[:40]!r}… ({len(value)} characters)"  # a 5 000-digit value is not echoed whole
        if isinstance(value, str) and not INTEGER_TEXT.fullmatch(value.strip(" \t\r\n")):
            self.fail(f"{shown} is not a valid integer (decimal digits, without '_')", param, ctx)
        if isinstance(value, str) and len(value.strip(" \t\r\n").lstrip("+-")) > 30:
            # beyond any count or seed (and Python refuses to read more than 4300 digits)
            self.fail(f"{shown} is too large", param, ctx)
        return super().convert(value, param, ctx)

    def _describe_range(self) -> str:
        """The range ``--help`` shows: none for an unbounded integer (click wrote ``x<=None``)."""
        if self.min is None and self.max is None:
            return ""
        return super()._describe_range()


#: The seeds the optimizer's generators accept: 0 … 2**32 − 1 (``exotune.optimization.spec.MAX_SEED``,
#: not imported: the command line loads no library module before a command runs).
MAX_SEED = 2**32 - 1


def _note_first_compile() -> None:
    """One stderr line while the compiled kernels are built for this machine (first batch run)."""
    from .numerics.engine import compiled, kernels_cached

    if compiled() and not kernels_cached():
        click.echo("exotune: compiling the analysis kernels for this machine (first run only, about a minute; "
                   "later runs start at once)", err=True)


SINGLE_DESIGN_COMMANDS = ("design", "sea", "analyze", "export", "certify", "codegen", "identify", "simulate", "init")


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="exotune")
@click.pass_context
def cli(ctx):
    """exotune: robust stability analysis and tuning of strength-amplification exoskeletons
    (double compliance shaping, Thomas, Coholich & Sentis). Gains are in torque units
    (docs/method.md#double-compliance-shaping).

    \b
    Inputs: design files (docs/design-file.md), sweep specs (docs/sweep-spec.md),
    optimize specs (docs/optimize-spec.md), controller files (docs/controller-file.md);
    `exotune init DIR` writes commented templates of the first three.
    Outputs: reports on stdout (--json: one JSON object); files only where an option
    names them (-o, --plots, --pareto); errors as one line `exotune: error: …`, exit 2.
    \f

    Parameters
    ----------
    ctx : click.Context
        The command line's context (click passes it; the numpy engine is entered for the
        single-design commands).
    """
    if ctx.invoked_subcommand in SINGLE_DESIGN_COMMANDS:
        # one design: the numpy engine answers at once; compiling the kernels pays only for batches
        from .numerics.beside import one_shot
        from .numerics.engine import numpy_engine

        ctx.with_resource(numpy_engine())
        # one command per process: independent halves of the work may run in two processes at once
        ctx.with_resource(one_shot())


@cli.command("init")
@click.argument("directory", metavar="DIR", default=".")
def init_cmd(directory):
    """Write commented starting files into DIR (default: here): design.yaml (docs/design-file.md),
    sweep.yaml (docs/sweep-spec.md) and optimize.yaml (docs/optimize-spec.md). Never overwrites."""
    from .api import init

    for p in init(directory):
        _echo(f"wrote {p}")
    _echo(f"next: exotune analyze {directory.rstrip('/') + '/' if directory != '.' else ''}design.yaml")


@cli.command("design")
@click.argument("design_file", metavar="DESIGN.yaml")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.option("--plots", "plots", metavar="DIR", default=None, help="Write Bode plots (PNG) of C4, C5, Ĉ5, C7, G_v.")
def design_cmd(design_file, as_json, plots):
    """Gains and nominal transfer functions of a design file (paper §IV,
    docs/method.md#double-compliance-shaping).

    DESIGN.yaml is a design file (docs/design-file.md; `exotune init` writes one). The report goes
    to stdout (--json: one JSON object); --plots DIR writes the Bode PNGs into DIR."""
    from .api import design

    r = design(design_file, plots=plots)
    _echo(r.to_json() if as_json else r.to_text())


@cli.command("sea")
@click.argument("sea_file", metavar="SEA.yaml")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
def sea_cmd(sea_file, as_json):
    """Analyse a plain SEA compliance-shaping controller (paper §II-B).

    SEA.yaml holds a plant and the four SEA gains (docs/design-file.md#sea-files); the report goes
    to stdout (--json: one JSON object)."""
    from .api import sea

    r = sea(sea_file)
    _echo(r.to_json() if as_json else r.to_text())


@cli.command("analyze")
@click.argument("design_file", metavar="DESIGN.yaml")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.option("--plots", "plots", metavar="DIR", default=None, help="Write the analysis plots to DIR.")
@click.option("--cross-check", "cross_check", is_flag=True,
              help="Also compare the exact verdicts with closed-loop roots of two Padé models (docs/method.md#analyses-and-metrics).")
@click.option("--time-budget-s", "time_budget_s", default=None, metavar="S",
              help="Stop the analysis beyond this many seconds (default 600); nothing is written then.")
def analyze_cmd(design_file, as_json, plots, cross_check, time_budget_s):
    """Margins (latency, plant uncertainty), stability, passivity, DOB margins and
    amplification of a design (docs/method.md#analyses-and-metrics).

    DESIGN.yaml is a design file (docs/design-file.md). The report goes to stdout (--json: one
    JSON object); --plots DIR writes the analysis PNGs into DIR."""
    from .api import analyze

    r = analyze(design_file, cross_check=cross_check, plots=plots, time_budget_s=time_budget_s)
    _echo(r.to_json() if as_json else r.to_text())


@cli.command("sweep")
@click.argument("spec_file", metavar="SPEC.yaml")
@click.option("-o", "--out", "out", required=True, metavar="DIR", help="Output directory (resumable).")
@click.option("--workers", type=_Int(min=1), default=None, help="Local worker processes.")
@click.option("--dask", "dask_address", default=None, metavar="ADDRESS", help="Run on this Dask scheduler.")
@click.option("--sample", type=_Int(min=1), default=None, metavar="N", help="Random sample of N grid points.")
@click.option("--seed", type=_Int(min=0), default=None, metavar="S", help="Seed for --sample (default 0).")
@click.option("--chunk-size", type=_Int(min=1), default=None, metavar="N", help="Design points per chunk.")
@click.pass_context
def sweep_cmd(ctx, spec_file, out, workers, dask_address, sample, seed, chunk_size):
    """Vectorized, chunked, resumable parameter sweep.

    SPEC.yaml is a sweep spec (docs/sweep-spec.md). Writes DIR/manifest.json and one Parquet file
    per chunk in DIR/chunks; rerun the same command to resume; `exotune report DIR` next.
    Ctrl-C (exit 130) or SIGTERM (exit 143) stops the workers and keeps the finished chunks."""
    import sys

    from .api import sweep
    from .sweeps import TqdmProgress

    _note_first_compile()
    try:
        sweep(spec_file, out, workers=workers, dask_address=dask_address, sample=sample, seed=seed,
              chunk_size=chunk_size, progress=TqdmProgress(sys.stderr))
    except KeyboardInterrupt:  # the sweep recorded itself as interrupted and said how to resume
        ctx.exit(130)  # 128 + SIGINT, as a shell reports a command ended by Ctrl-C


@cli.command("report")
@click.argument("sweep_dir", metavar="DIR")
@click.option("-o", "--out", "out", default=None, metavar="OUT",
              help="Directory to write the report into (default: DIR/report).")
def report_cmd(sweep_dir, out):
    """Stability maps and summary tables of a sweep (docs/sweep-spec.md).

    Reads the sweep directory DIR written by `exotune sweep` and writes summary.md, one CSV table
    per axis (axis_<path>.csv) and the PNG maps into OUT (default DIR/report); prints where.
    """
    from .api import report

    _echo(report(sweep_dir, out).to_text())


@cli.command("optimize")
@click.argument("spec_file", metavar="SPEC.yaml")
@click.option("-o", "--out", "out", required=True, metavar="DESIGN.yaml", help="Optimized design file to write.")
@click.option("--seed", type=_Int(min=0, max=MAX_SEED), default=None, metavar="S",
              help="Seed, 0 to 4294967295 (deterministic per seed).")
@click.option("--pareto", "pareto_csv", default=None, metavar="FILE.csv",
              help="Also write the Pareto front (objective vs robust fraction) as CSV.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.pass_context
def optimize_cmd(ctx, spec_file, out, seed, pareto_csv, as_json):
    """Maximize α (or another objective) under robust-stability, latency-margin, passivity,
    DOB-margin and amplification constraints; by default the design keeps a latency margin of one
    sample period (0.5 ms without a sample rate). Exit code 1 when no feasible design exists in
    the bounds (the broken constraints of the best design are listed)."""
    from .api import optimize

    _note_first_compile()
    r = optimize(spec_file, out, seed=seed, pareto_csv=pareto_csv)
    _echo(r.to_json() if as_json else r.to_text())
    if not r.feasible:
        ctx.exit(1)


@cli.command("export")
@click.argument("design_file", metavar="DESIGN.yaml")
@click.option("--sample-rate-hz", "sample_rate_hz", default=None, metavar="F",
              help="Runtime sample rate [Hz] (default: the design's implementation.sample_rate_hz).")
@click.option("-o", "--out", "out", required=True, metavar="CONTROLLER.yaml", help="Controller file to write.")
@click.option("--require-latency-margin-s", "require_latency_margin_s", default=None, metavar="S",
              help="Latency margin [s] the file must keep; certify fails below it (default: the design's "
                   "requirements section, else one sample period; 0: none).")
@click.option("--time-budget-s", "time_budget_s", default=None, metavar="S",
              help="Refuse or stop the export beyond this many seconds (default 600); nothing is written then.")
@click.option("--allow-uncertified", "allow_uncertified", is_flag=True,
              help="Write the file even when it fails its own requirements (recorded in its provenance).")
def export_cmd(design_file, sample_rate_hz, out, require_latency_margin_s, time_budget_s, allow_uncertified):
    """Export the discrete-time runtime controller as YAML.

    DESIGN.yaml is a design file (docs/design-file.md); the controller file -o (docs/controller-
    file.md) is written atomically; `exotune certify CONTROLLER.yaml` next. Exit code 1, nothing
    written, when the controller would not certify (its sampled-data verdicts or latency margin
    against its requirements), unless --allow-uncertified."""
    from .api import export
    from .options import latency_requirement_value

    if require_latency_margin_s is not None:  # within [0, 1] s, as a design file's requirements section
        require_latency_margin_s = latency_requirement_value("--require-latency-margin-s", require_latency_margin_s)
    c = export(design_file, sample_rate_hz, out, require_latency_margin_s=require_latency_margin_s,
               time_budget_s=time_budget_s, allow_uncertified=allow_uncertified)
    _echo(c.summary())


@cli.command("certify")
@click.argument("controller_file", metavar="CONTROLLER.yaml")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.option("--time-budget-s", "time_budget_s", default=None, metavar="S",
              help="Refuse or stop the analysis beyond this many seconds (default 600).")
@click.option("--precision", "precision", default=None, metavar="float64|float32",
              help="Analyse the file as if exported for this target arithmetic (the file is not changed).")
@click.pass_context
def certify_cmd(ctx, controller_file, as_json, time_budget_s, precision):
    """Exact sampled-data analysis of an exported controller file (docs/controller-file.md). Exit code 0: certified,
    1: analysed but not certified (the reasons are listed), 2: invalid file."""
    from .api import certify

    r = certify(controller_file, precision=precision, time_budget_s=time_budget_s)
    _echo(r.to_json() if as_json else r.to_text())
    if not r.certified:
        ctx.exit(1)


@cli.command("codegen")
@click.argument("controller_file", metavar="CONTROLLER.yaml")
@click.option("-o", "--out", "out", required=True, metavar="DIR", help="Directory for the C files.")
@click.option("--allow-uncertified", "allow_uncertified", is_flag=True,
              help="Write the C of a file that does not certify, stamped as uncertified.")
def codegen_cmd(controller_file, out, allow_uncertified):
    """Write the C99 port of a controller file's runtime (docs/deploying.md):
    exotune_controller.{h,c} and exotune_golden_test.c, which checks the port on the target. The
    file is certified first: one that does not certify is refused (exit 1, the reasons named,
    nothing written) unless --allow-uncertified. The code carries the file's sha256, the exotune
    version and the verdict. All files are written or none."""
    from .api import codegen

    _echo(codegen(controller_file, out, allow_uncertified=allow_uncertified).to_text())


@cli.command("identify")
@click.argument("log_files", metavar="LOG.csv [LOG2.csv ...]", nargs=-1, required=True)
@click.option("-o", "--out", "out", default=None, metavar="PLANT.yaml",
              help="Write the plant and uncertainty sections (YAML) for a design file.")
@click.option("--delay-s", "delay_s", default=None, metavar="S|auto",
              help="Delay [s] from tau_cmd to the applied torque (logs with a tau_cmd column; default 0; auto: estimated).")
@click.option("--filter-hz", "filter_hz", default=None, metavar="F",
              help="Corner of the state-variable filter [Hz] (default 20, at most a hundredth of the rate; "
                   "accepted: rate/2500 to rate/25).")
@click.option("--sample-rate-hz", "sample_rate_hz", default=None, metavar="F",
              help="Sample rate [Hz], overriding the time column (which may then be absent).")
@click.option("--friction", "friction", is_flag=True, help="Estimate Coulomb friction F_c·sign(θ̇_m) in the motor equation.")
@click.option("--fix", "fix", multiple=True, metavar="NAME=VALUE",
              help="A known parameter (design-file key or symbol, SI units); repeatable.")
@click.option("--validate", "validate", default=None, metavar="LOG2.csv",
              help="Validate on a second log: simulated-output NRMSE, residual tests, frequency responses.")
@click.option("--folds", "folds", default=None, type=_Int(), metavar="K", help="K-fold cross-validation on LOG.csv itself.")
@click.option("--plots", "plots", metavar="DIR", default=None,
              help="Write the Bode overlays and residual tests (PNG) and frequency_response.csv to DIR.")
@click.option("--frf-csv", "frf_csv", default=None, metavar="FRF.csv", help="Write the measured frequency responses (CSV).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.pass_context
def identify_cmd(ctx, log_files, out, delay_s, filter_hz, sample_rate_hz, friction, fix, validate, folds, plots,
                 frf_csv, as_json):
    """Identify the plant (J_m, B_m, K_s, J_j, K_c) from a measured log, or from several logs
    together (docs/identification.md).

    LOG.csv holds a header row of column names and one row per sample (t, theta_m, tau_s, tau_m or
    tau_cmd; theta_j, tau_c, theta_h for more parameters); several logs (same columns, one rate)
    are stacked, each filtered on its own. Each equation is identified on its own.
    Exit code 0: every parameter the columns allow identified; 1: some parameter not identified
    (the others are written) or not physical (≤ 0: nothing is written); 2: bad input, or a log
    that excites no parameter. The written uncertainty is the larger of 3 SE and the model error
    the validation measures (--validate LOG2.csv, --folds K; docs/identification.md#validation)."""
    from .api import identify
    from .options import number_value

    delay = "0" if delay_s is None else delay_s
    if delay.strip().lower() != "auto":
        delay = number_value("--delay-s", delay, False)
    fh = None if filter_hz is None else number_value("--filter-hz", filter_hz, True)
    fs = None if sample_rate_hz is None else number_value("--sample-rate-hz", sample_rate_hz, True)
    r = identify(list(log_files) if len(log_files) > 1 else log_files[0], out, delay_s=delay, filter_hz=fh,
                 sample_rate_hz=fs, friction=friction, fix=fix, validate=validate, folds=folds, frf_csv=frf_csv,
                 plots=plots)
    _echo(r.to_json() if as_json else r.to_text())
    if not r.complete:
        ctx.exit(1)


@cli.command("excite")
@click.option("-o", "--out", "out", required=True, metavar="EXC.csv",
              help="The command to play (CSV: t [s], tau_cmd [N·m]); its description goes to EXC.json beside it.")
@click.option("--sample-rate-hz", "sample_rate_hz", required=True, metavar="F", help="The rig's sample rate [Hz].")
@click.option("--f-lo-hz", "f_lo_hz", required=True, metavar="F", help="Lowest frequency of the band [Hz] (> 0).")
@click.option("--f-hi-hz", "f_hi_hz", required=True, metavar="F", help="Highest frequency of the band [Hz] (below fs/2).")
@click.option("--peak-nm", "peak_nm", default=None, metavar="A", help="Peak of the command [N·m] (or --rms-nm).")
@click.option("--rms-nm", "rms_nm", default=None, metavar="A", help="RMS of the command [N·m] (or --peak-nm).")
@click.option("--period-s", "period_s", default=None, metavar="S",
              help="Period [s], whole samples (default 1/f_lo rounded down, so the first line is ≥ f_lo): the "
                   "frequency resolution is 1/period.")
@click.option("--periods", "periods", default=None, type=_Int(min=1), metavar="P",
              help="Number of periods (default: whole periods making 20 s, at least 2).")
@click.option("--duration-s", "duration_s", default=None, metavar="S", help="Whole periods within this duration [s].")
@click.option("--lines", "lines", default="all", show_default=True, type=click.Choice(["all", "odd", "random-odd", "log"]),
              help="Which harmonics of 1/period in the band are excited.")
@click.option("--seed", "seed", default=None, type=_Int(min=0), metavar="S", help="The draw of --lines random-odd (default 0).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
def excite_cmd(out, sample_rate_hz, f_lo_hz, f_hi_hz, peak_nm, rms_nm, period_s, periods, duration_s, lines, seed,
               as_json):
    """Write a Schroeder-phased multisine motor command for an identification experiment
    (docs/identification.md#excite): CSV with t [s] and tau_cmd [N·m], the log format `exotune
    identify` reads, and its description (units, lines, phases, crest factor) as EXC.json. Prints
    the crest factor, the frequency resolution and the number of excited lines."""
    from .api import excite
    from .options import number_value

    num = {name: None if v is None else number_value(name, v) for name, v in (
        ("--sample-rate-hz", sample_rate_hz), ("--f-lo-hz", f_lo_hz), ("--f-hi-hz", f_hi_hz), ("--peak-nm", peak_nm),
        ("--rms-nm", rms_nm), ("--period-s", period_s), ("--duration-s", duration_s))}
    e = excite(out, sample_rate_hz=num["--sample-rate-hz"], f_lo_hz=num["--f-lo-hz"], f_hi_hz=num["--f-hi-hz"],
               peak_nm=num["--peak-nm"], rms_nm=num["--rms-nm"], period_s=num["--period-s"], periods=periods,
               duration_s=num["--duration-s"], lines=lines, seed=seed)
    _echo(e.to_json() if as_json else e.to_text())


@cli.command("simulate")
@click.argument("input_file", metavar="DESIGN.yaml|CONTROLLER.yaml")
@click.option("--scenario", required=True,
              type=click.Choice(["locked-output", "dob-friction", "light-mass", "saturation", "backlash"]),
              help="What to run (see docs/cli.md#simulate).")
@click.option("--sample-rate-hz", "sample_rate_hz", default=None, metavar="F",
              help="Sample rate for a design file (default: its implementation.sample_rate_hz).")
@click.option("--human-inertia", "human_inertia", default=None, metavar="KGM2",
              help="Human inertia [kg·m²] (> 0) instead of the scenario's.")
@click.option("--duration", "duration", default=None, metavar="S", help="Run length [s] (> 0) instead of the scenario's.")
@click.option("--start", "start", type=click.Choice(["bumpless", "zero"]), default="bumpless", show_default=True,
              help="Initial controller state: at equilibrium with the initial measurements, or zero.")
@click.option("--joint-angle", "joint_angle", default=None, metavar="RAD",
              help="Run the gain-schedule entry (plant and controller) nearest this joint angle [rad], "
                   "within the schedule's angles.")
@click.option("--plots", "plots", metavar="DIR", default=None, help="Write time-series plots (PNG) to DIR.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (summary, no time series).")
@click.option("--time-budget-s", "time_budget_s", default=None, metavar="S",
              help="Stop the simulation beyond this many seconds (default 600); nothing is written then.")
def simulate_cmd(input_file, scenario, sample_rate_hz, human_inertia, duration, start, joint_angle, plots, as_json,
                 time_budget_s):
    """Nonlinear time-domain run of the runtime controller on the plant (friction, backlash,
    saturation), judged by the growth rate of its oscillation envelope."""
    import sys
    import time

    from .api import simulate
    from .options import number_value

    human_inertia, duration, joint_angle = (None if v is None else number_value(n, v, positive=n != "--joint-angle")
                                            for n, v in (("--human-inertia", human_inertia), ("--duration", duration),
                                                         ("--joint-angle", joint_angle)))

    t0 = time.monotonic()

    def progress(frac):  # on a terminal only, for runs that last more than a second
        if shown or time.monotonic() - t0 > 1.0:
            shown.append(frac)
            click.echo(f"\rexotune simulate: {frac:4.0%}", err=True, nl=frac >= 1.0)

    shown: list = []
    r = simulate(input_file, scenario, sample_rate_hz=sample_rate_hz, human_inertia=human_inertia, duration=duration,
                 start=start, joint_angle=joint_angle, plots=plots, progress=progress if sys.stderr.isatty() else None,
                 time_budget_s=time_budget_s)
    _echo(r.to_json() if as_json else r.to_text())


def main(argv=None) -> None:
    """Console entry point (``exotune = exotune.cli:main``).

    Parameters
    ----------
    argv : list of str or None, optional
        The arguments; None for ``sys.argv[1:]``.
    """
    _spell_out_unencodable()
    cli.main(args=argv, prog_name="exotune")


#: ASCII for the symbols of exotune's reports that 8-bit code pages lack (others: their NFKD
#: decomposition when it is ASCII, else "?")
_SPELLED = {"≤": "<=", "≥": ">=", "−": "-", "∞": "inf", "≈": "~", "×": "x", "…": "...", "→": "->", "–": "-",
            "—": "-", "·": ".", "²": "^2", "³": "^3", "°": " deg", "±": "+-", "√": "sqrt", "Δ": "Delta",
            "ω": "w", "θ": "theta", "τ": "tau", "α": "alpha", "ζ": "zeta", "η": "eta", "φ": "phi", "µ": "u",
            "μ": "u", "⁻": "^-", "¹": "^1", "⁰": "^0"}


def _spelled(err):
    import unicodedata

    out = []
    for ch in err.object[err.start:err.end]:
        rep = _SPELLED.get(ch)
        if rep is None:
            d = unicodedata.normalize("NFKD", ch).encode("ascii", "ignore").decode("ascii")
            rep = d or "?"
        out.append(rep)
    return "".join(out), err.end


def _spell_out_unencodable() -> None:
    """A terminal or pipe whose encoding lacks a symbol of the report (cp1252 has no ≤, cp437 no
    ·) gets it spelled in ASCII (``<=``) instead of failing the whole output."""
    import codecs
    import sys

    codecs.register_error("exotune-spell", _spelled)
    for stream in (sys.stdout, sys.stderr):
        enc = (getattr(stream, "encoding", None) or "").lower().replace("_", "-")
        if enc not in ("utf-8", "utf8") and hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(errors="exotune-spell")
            except (ValueError, OSError):  # a stream that cannot change its error handler keeps it
                pass


if __name__ == "__main__":
    main()
