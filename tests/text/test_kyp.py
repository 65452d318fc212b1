"""exotune.text.kyp: the lines of the KYP passivity certificates (verdict, shortage with its unit,
witness frequency, reason)."""

import math

from exotune.text.kyp import format_certificates

UNIT = "rad/(N·m·s)"


def _c(passive, shortage, wf=None, reason="the LMI is infeasible"):
    return {"model": "nominal", "passive": passive, "shortage": shortage, "shortage_unit": UNIT,
            "witness_frequency_hz": wf, "reason": reason}


def test_certificate_lines():
    certs = {"a": _c(True, 0.0), "b": _c(False, 1.23456e-4, 12.345), "c": {**_c(False, 2e-3, math.inf), "model": "DOB"},
             "d": _c(None, None, reason="the solver stalled"), "error": "KYP: not computed (no cvxopt)"}
    assert format_certificates(certs, indent="- ") == [
        "- KYP certificate, nominal: passive (verified); shortage 0 rad/(N·m·s)",
        "- KYP certificate, nominal: NOT passive; shortage 0.0001235 rad/(N·m·s) (Re{jω C7} minimum at 12.35 Hz)",
        "- KYP certificate, DOB: NOT passive; shortage 0.002 rad/(N·m·s) (Re{jω C7} approaches its infimum as ω → ∞)",
        "- KYP certificate, nominal: undecided — the solver stalled",
        "- KYP: not computed (no cvxopt)",
    ]


def test_no_certificates_and_an_infinite_shortage():
    assert format_certificates(None) == [] and format_certificates({}) == []
    (line,) = format_certificates({"x": _c(False, math.inf, float("nan"))})
    assert line == "  KYP certificate, nominal: NOT passive — the LMI is infeasible"
