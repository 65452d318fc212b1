#!/usr/bin/env bash
# Regenerate every study in results/ (figures + Markdown/CSV summaries only; the Parquet sweep data
# go to ${EXOTUNE_STUDY_DATA:-${TMPDIR:-/tmp}/exotune-studies}, outside the repository).
#
#   studies/run_all.sh [--workers N] [--resume]      (default: 2 workers, fresh sweeps)
#
# Studies: (a) alpha_delay  — α × delay (× ζ̂) robust-stability map
#          (b) dob_delay    — DOB cutoff × delay → DOB delay margin
#          (c) cuff_inertia — cuff stiffness K_c × lightest stable human inertia
#          (d) sample_rate  — controller sample rate × lightest stable inertia (sampled-data model)
#          (e) pipeline     — optimize → export → certify → simulate on one design
#          (f) paper        — the paper's Table II and Figs. 4, 5, 6, 8, 9 reproduced, with comparison pages
#          (g) sampled_optimum — optimize with a sample rate against a dense sampled-data reference
#          (h) identification — excite → simulated rig → identify → validate → analyze with the plant
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
PYTHON="${PYTHON:-python}"
for study in alpha_delay dob_delay cuff_inertia; do
    echo "== studies/${study}.py" >&2
    "$PYTHON" "studies/${study}.py" "$@"
done
echo "== studies/sample_rate.py" >&2
"$PYTHON" studies/sample_rate.py   # no sweep: sampled-data verdicts by bisection (seconds)
echo "== studies/pipeline.py" >&2
"$PYTHON" studies/pipeline.py
echo "== studies/sampled_optimum.py" >&2
"$PYTHON" studies/sampled_optimum.py   # optimize with a rate against a dense reference (minutes)
echo "== studies/identification_workflow.py" >&2
"$PYTHON" studies/identification_workflow.py
echo "== studies/paper_figures.py" >&2
"$PYTHON" studies/paper_figures.py   # no sweep: analysis + two 1 kHz simulations (about 20 s)
echo "results written to results/{alpha_delay,dob_delay,cuff_inertia,sample_rate,pipeline,sampled_optimum,identification,paper}/" >&2
