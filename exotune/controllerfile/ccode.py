"""C99 source of the runtime controller of a controller file (``exotune codegen``).

The generated ``exotune_controller.c`` is a line-by-line port of the reference runtime
(:mod:`exotune.controllerfile.runtime`, docs/controller-file.md#what-the-runtime-computes): the same
static gains, second-order sections in direct form II transposed, the DOB's algebraic loop
solved in closed form, the optional clamp before the DOB sees the command, and the same
refusals (a non-finite input, a command or state that overflows: fault code, state unchanged).
Every coefficient is written with 17 significant digits, so it is the file's double exactly, and
every sum runs in the reference runtime's order: compiled without contraction of a·b + c into a
fused multiply-add (``-ffp-contract=off``; GCC contracts by default on targets with FMA), the
port reproduces the reference runtime's outputs to rounding. The C text of the step, the
hardening (fast-math refused, subnormals flushed, a self-check at init) and the schedule switch
live in :mod:`exotune.controllerfile.cstep`; ``exotune_golden_test.c``
(:mod:`exotune.controllerfile.cgolden`) checks every controller, every fault path and the clamp
against the reference runtime with a tolerance per output derived from its rounding: run it on
the target before the controller drives a joint.

:func:`write_c_sources` certifies the file first (once) and refuses one that does not certify
unless told otherwise; the code carries the file's sha256, the exotune version and the verdict.

A float32 file (``implementation.precision: float32``) gets the float32 port of its realization
instead (:mod:`exotune.controllerfile.ccode32`): the same files, API and return codes.

No allocation, no recursion, no library call except ``isfinite``, ``isnan``, ``isinf`` and
``fabs`` from ``math.h``; the state is a plain struct the caller owns (one per joint).

References
----------
docs/deploying.md; docs/controller-file.md#c-runtime; paper §V (the 1 kHz runtime of the
experiments).
"""

from __future__ import annotations

import hashlib
import math
import os

from ..errors import ConfigError, RunFailed
from .ccode32 import generate32
from .cgolden import golden_program, golden_rows
from .cheader import C_FLAGS, HeaderParts, c_table, controller_tables, header_text, source_head
from .cstep import (BUMPLESS_TAU_S, CHECKS_C, FLUSH_BELOW, RETURN_CODES, SIGNALS, STEP_C, c_double,
                    controllers_of, layouts_of, state_maps)
from .model import ControllerFile, as_controller_file
from .precision import precision_of
from .results import GeneratedC

__all__ = ["c_sources", "write_c_sources", "check_size", "C_FILES", "C_FLAGS", "MIN_COEFFICIENT",
           "MAX_SECTIONS_PER_CONTROLLER", "MAX_SCHEDULE_ENTRIES"]

C_FILES = ("exotune_controller.h", "exotune_controller.c", "exotune_golden_test.c")
# a nonzero coefficient below this magnitude could make a product with a flushed-size value subnormal
MIN_COEFFICIENT = 1e-150
# the largest controller file codegen takes (exotune export writes 5-40 sections per controller and a
# schedule of a few entries): certification and the golden vectors grow with the cube of the sections
MAX_SECTIONS_PER_CONTROLLER = 128
MAX_SCHEDULE_ENTRIES = 64


def check_size(doc: ControllerFile | dict) -> None:
    """Refuse, before any heavy work, a controller file larger than codegen takes: more than
    :data:`MAX_SECTIONS_PER_CONTROLLER` second-order sections in a controller (nominal or a
    gain-schedule entry, all its filters together) or more than :data:`MAX_SCHEDULE_ENTRIES`
    gain-schedule entries.

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file.

    Raises
    ------
    ConfigError
        Naming the field and the limit.
    """
    cf = as_controller_file(doc)
    entries = cf.schedule_entries
    if len(entries) > MAX_SCHEDULE_ENTRIES:
        raise ConfigError("gain_schedule.entries", f"{len(entries)} entries: codegen takes at most "
                          f"{MAX_SCHEDULE_ENTRIES} (exotune export writes a few)")
    ctrls = [("controller.filters", cf.controller)]
    ctrls += [(f"gain_schedule.entries[{i}].controller.filters", cf.entry_view(e).controller)
              for i, e in enumerate(entries)]
    for field, c in ctrls:
        n = sum(len(f.sos) for f in c.filters)
        if n > MAX_SECTIONS_PER_CONTROLLER:
            raise ConfigError(field, f"{n} second-order sections: codegen takes at most "
                              f"{MAX_SECTIONS_PER_CONTROLLER} per controller (exotune export writes 5-40)")


def _tables(ctrls) -> dict:
    """Flat coefficient tables of every controller, in the reference runtime's order; a filter's
    first section is counted from its controller's first section (the state's index)."""
    gains, filters, sections = [], [], []
    rows = []
    for (_label, _angle, rt), layout in zip(ctrls, layouts_of(ctrls)):
        g0, f0, s0 = len(gains), len(filters), len(sections)
        gains += [(SIGNALS.index(s), g) for s, g in rt.gains.items()]
        for signal, f in [(s, f) for s, f in rt.filters] + [("tau_cmd", f) for f in rt.loop]:
            coef = f.coefficients
            filters.append((-1 if signal == "tau_cmd" else SIGNALS.index(signal), len(sections) - s0, len(coef)))
            sections.extend(coef)
        rows.append((g0, len(gains) - g0, f0, len(rt.filters), len(rt.loop), s0, len(sections) - s0, layout,
                     rt.loop_feedthrough))
    small = [x for _s, g in gains for x in (g,)] + [x for c in sections for x in c] + [r[-1] for r in rows]
    small = [x for x in small if x != 0.0 and abs(x) < MIN_COEFFICIENT]
    if small:
        raise ConfigError("controller", f"a coefficient of magnitude {abs(small[0]):.3g} < {MIN_COEFFICIENT:g}: "
                          "the C port's constant step time needs every nonzero coefficient at least that large")
    return {"gains": gains, "filters": filters, "sections": sections, "controllers": rows}


def _trace(doc, trace: dict | None) -> dict:
    """The traceability constants: the file's sha256, the exotune version, the verdict."""
    t = {"sha256": "unknown (generated from a document, not a file)", "certified": False,
         "verdict": "NOT CHECKED", "reasons": ()}
    t.update(trace or {})
    return t


def _parts64(doc: ControllerFile) -> HeaderParts:
    """The float64 port's parts of the shared header (:func:`~exotune.controllerfile.cheader.header_text`)."""
    fs = float(doc.sample_rate_hz)
    decay = math.exp(-1.0 / (fs * BUMPLESS_TAU_S))
    constants = ("#define EXOTUNE_PRECISION_BITS 64  /* double arithmetic (the file's implementation.precision) */\n"
                 f"#define EXOTUNE_FLUSH_BELOW {c_double(FLUSH_BELOW)}  /* inputs and states below this magnitude are "
                 f"zero: constant step time */\n"
                 f"#ifndef EXOTUNE_BUMPLESS_DECAY  /* per sample: time constant {BUMPLESS_TAU_S:g} s (may be defined, "
                 f"0 <= d < 1, when compiling) */\n#define EXOTUNE_BUMPLESS_DECAY {c_double(decay)}\n#endif\n"
                 "#define EXOTUNE_HAS_BUMPLESS 1  /* EXOTUNE_SWITCH_BUMPLESS is available */\n")
    modes = ("#define EXOTUNE_SWITCH_RESET 0     /* the new controller starts from the zero state */\n"
             "#define EXOTUNE_SWITCH_BUMPLESS 1  /* states carried over (same layout), command continuous at the "
             "switch */\n")
    return HeaderParts("", constants, RETURN_CODES, modes, STATE64_H, INIT64_H, SWITCH64_H)


STATE64_H = """typedef struct {
    unsigned int magic; /* EXOTUNE_STATE_MAGIC once exotune_init succeeded; anything else: not initialized */
    int controller;     /* which controller runs (0: nominal); -1: not initialized */
    int has_last;       /* last[] holds the last accepted inputs */
    double limit_nm;    /* clamp of the command [N.m] before the DOB sees it; 0: none */
    double offset_nm;   /* bumpless-switch offset added to the command [N.m], decays */
    double last[5];     /* the last accepted inputs (theta_m, omega_m, tau_s, dtau_s, tau_c) */
    double z[EXOTUNE_MAX_SECTIONS][2];  /* section states of the running controller, DF-II transposed */
} exotune_state;
"""
INIT64_H = """/* Zero state (then call exotune_start with the first reading), controller
 * 0...EXOTUNE_N_CONTROLLERS-1, limit_nm > 0 clamps (0: no clamp); checks the floating-point
 * environment. EXOTUNE_OK, EXOTUNE_ERR_ARGUMENT (nothing changed) or
 * EXOTUNE_ERR_FLOAT_ENV (the state cannot be stepped). */"""
SWITCH64_H = """/* Run controller `controller` from the next step. mode EXOTUNE_SWITCH_RESET: zero state.
 * EXOTUNE_SWITCH_BUMPLESS: the states are carried over (both controllers must have the same layout:
 * otherwise EXOTUNE_ERR_ARGUMENT, nothing changed; every entry of an exported schedule has it)
 * and the difference between the old controller's command and the new one's, both for the last
 * accepted inputs (exotune_step's or exotune_start's), becomes an offset added to the command, which decays by
 * EXOTUNE_BUMPLESS_DECAY per sample: the command does not jump at the switch. EXOTUNE_OK,
 * EXOTUNE_ERR_ARGUMENT or EXOTUNE_FAULT_OVERFLOW (state unchanged). */"""


def _source(doc: ControllerFile, ctrls, t: dict, trace: dict) -> str:
    L = source_head(doc, trace, CHECKS_C) + [
         "/* per static gain: input signal (0 theta_m, 1 omega_m, 2 tau_s, 3 dtau_s, 4 tau_c), gain */",
         "typedef struct { int signal; double gain; } exo_gain;",
         "/* per filter: input signal (-1: tau_cmd, the DOB loop), first section (of its controller), sections */",
         "typedef struct { int signal; int first; int count; } exo_filter;",
         "/* per section: b0, b1, b2, a1, a2 (a0 = 1) */",
         "typedef struct { double b0, b1, b2, a1, a2; } exo_section;",
         "/* per section: M (DF-II-transposed state = M (w[k], w[k-1])) and W = M^-1 (0: singular), for a bumpless switch */",
         "typedef struct { double m00, m01, m10, m11, w00, w01, w10, w11; } exo_map;",
         "/* per controller: first gain, gains, first filter, sensed filters, loop filters, first section,",
         " * sections, layout (same layout: a bumpless switch carries the states), g = sum of loop feed-throughs */",
         "typedef struct { int gain0, n_gains, filter0, n_sensed, n_loop, sec0, n_sections, layout; double g; } "
         "exo_controller;", ""]
    L += c_table("exo_gain", "GAINS", [f"{{{s}, {c_double(g)}}}" for s, g in t["gains"]], "{0, 0.0}")
    L += c_table("exo_filter", "FILTERS", [f"{{{s}, {a}, {n}}}" for s, a, n in t["filters"]], "{0, 0, 0}")
    L += c_table("exo_section", "SECTIONS", [f"{{{', '.join(c_double(x) for x in c)}}}" for c in t["sections"]],
                 "{0.0, 0.0, 0.0, 0.0, 0.0}")
    L += c_table("exo_map", "MAPS", [f"{{{', '.join(c_double(x) for x in state_maps(c))}}}" for c in t["sections"]],
                 "{0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}")
    L += controller_tables(t["controllers"], [c[0] for c in ctrls], c_double, [c[1] for c in ctrls[1:]])
    L.append(STEP_C)
    return "\n".join(L) + "\n"


def c_sources(doc: ControllerFile | dict, trace: dict | None = None) -> dict[str, str]:
    """The C99 port of the runtime controller of a validated controller file.

    Parameters
    ----------
    doc : ControllerFile or dict
        A controller file (:func:`exotune.controllerfile.fileio.load_controller_file`, or its mapping).
    trace : dict, optional
        What the code says about its origin: ``sha256`` (of the file's bytes), ``certified``
        (bool), ``verdict`` (``"CERTIFIED"``, ``"UNCERTIFIED ..."``) and ``reasons``;
        :func:`write_c_sources` fills it. Without it the code says ``NOT CHECKED``.

    Returns
    -------
    dict
        ``{file name: text}`` for :data:`C_FILES` (ASCII only): the header (API, signal units,
        return codes, traceability constants), the controller (every controller of the file:
        nominal and gain-schedule entries) and the golden test program.

    References
    ----------
    docs/deploying.md; docs/controller-file.md#c-runtime; the reference runtime
    :class:`exotune.controllerfile.Runtime`.

    Examples
    --------
    >>> from exotune.controllerfile import build_export, design_at_rate
    >>> from exotune.config import read_yaml
    >>> doc = build_export(design_at_rate(read_yaml("examples/paper.yaml"), 1000.0), 1000.0, analyses=False)
    >>> files = c_sources(doc)
    >>> sorted(files), "exotune_step" in files["exotune_controller.h"]
    (['exotune_controller.c', 'exotune_controller.h', 'exotune_golden_test.c'], True)
    """
    return _generate(as_controller_file(doc), _trace(doc, trace))[0]


def _generate(doc: ControllerFile, trace: dict) -> tuple[dict[str, str], int, int]:
    """(files, number of controllers, number of sections): the float64 port, or the float32 port of
    a float32 file (:mod:`exotune.controllerfile.ccode32`)."""
    check_size(doc)
    if precision_of(doc) == "float32":
        return generate32(doc, trace)
    ctrls = controllers_of(doc)
    t = _tables(ctrls)
    max_sections = max([1] + [row[6] for row in t["controllers"]])
    files = {
        "exotune_controller.h": header_text(doc, len(ctrls), max_sections, trace, _parts64(doc)),
        "exotune_controller.c": _source(doc, ctrls, t, trace),
        "exotune_golden_test.c": golden_program(doc, golden_rows(doc)),
    }
    return files, len(ctrls), len(t["sections"])


def write_c_sources(controller_file, out_dir, allow_uncertified: bool = False) -> GeneratedC:
    """``exotune codegen``: validate and certify a controller file, and write its C99 port
    (:func:`c_sources`) into ``out_dir``, all files or none.

    Parameters
    ----------
    controller_file : str or os.PathLike
        A controller file (``exotune export``).
    out_dir : str or os.PathLike
        Directory for :data:`C_FILES` (created; existing files of these names are replaced).
    allow_uncertified : bool
        Write the port of a file that does not certify; the code then says so
        (``EXOTUNE_CERTIFIED 0``, the reasons in the header, a warning from the golden test).

    Returns
    -------
    GeneratedC
        Where the files went, the number of controllers and sections, the compiler flags, the
        file's sha256 and the certification verdict.

    Raises
    ------
    ConfigError
        An invalid file, one larger than codegen takes (:func:`check_size`), or golden vectors its
        own controller does not reproduce (``golden``).
    RunFailed
        The file does not certify (:func:`exotune.controllerfile.certify.certify`, run once) and
        ``allow_uncertified`` is false: the reasons are named, nothing is written.

    References
    ----------
    docs/deploying.md#traceability; docs/controller-file.md#c-runtime.
    """
    from pathlib import Path

    from ..jsonio import write_outputs
    from .certify import certify, golden_problems
    from .fileio import load_controller_file

    from ..config.yamlio import read_guarded

    # the sha256 stamped into the C must be that of the bytes certified: the file is read (through
    # the guarded reader, as the load reads it) before the load and again after the certification
    sha = hashlib.sha256(read_guarded(os.fspath(controller_file))).hexdigest()
    doc = load_controller_file(controller_file)
    check_size(doc)  # before the heavy work: certification grows with the cube of the sections
    problems, _n, _err = golden_problems(doc)
    if problems:
        raise ConfigError("golden", problems[0] + " (was the file edited? re-export it)")
    cert = certify(doc)
    if hashlib.sha256(read_guarded(os.fspath(controller_file))).hexdigest() != sha:
        raise ConfigError(os.fspath(controller_file), "the file changed while codegen read and certified it: "
                                                      "nothing written; run codegen again")
    if not cert.certified and not allow_uncertified:
        raise RunFailed(f"not written: {controller_file} does not certify: {'; '.join(cert.reasons)} "
                        "(`allow_uncertified` writes C stamped as uncertified)")
    verdict = "CERTIFIED" if cert.certified else "UNCERTIFIED (generated with --allow-uncertified)"
    trace = {"sha256": sha, "certified": cert.certified, "verdict": verdict, "reasons": tuple(cert.reasons)}
    files, n_ctrl, n_sec = _generate(doc, trace)
    write_outputs(dirs={out_dir: {k: v.encode("ascii") for k, v in files.items()}})
    return GeneratedC(Path(out_dir), C_FILES, n_ctrl, n_sec, C_FLAGS, sha, cert.certified, tuple(cert.reasons))
