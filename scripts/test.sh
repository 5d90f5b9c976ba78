#!/usr/bin/env bash
# `make test` after the install: the static checks (lint, types, the app's unit tests) in
# the background while pytest runs on both cores, their output after pytest's. Fails if
# either fails; pytest's "no tests collected" (exit code 5) is a failure too.
set -u
cd "$(dirname "$0")/.."
# one BLAS thread per process: two test workers on two cores, each with OpenBLAS's own
# spinning threads, ran the identification tests 2.5x slower (docs/benchmarks.md)
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
# the lab's bytecode, written once: every process the suite starts (about forty servers,
# their engines and workers) compiled the sources again where PYTHONDONTWRITEBYTECODE is set
# (0.25 s of CPU each for the web process); stale files are recompiled, never trusted
.venv/bin/python -m compileall -q backend/elab >/dev/null
checks=$(mktemp)
( make --no-print-directory lint typecheck frontend-test >"$checks" 2>&1; echo $? >"$checks.rc" ) &
# three workers on two cores: a third of the suite's time is waiting on real time (runs at
# 1 kHz, a browser drawing, a server starting) and a third worker fills it (2026-11-27,
# quiet: pytest 600 s with two, 500-536 s with three; the machine 8 % idle with three)
.venv/bin/python -m pytest -n "${ELAB_TEST_WORKERS:-3}" --dist loadscope --no-loadscope-reorder "$@"
tests=$?
wait
echo "== lint, typecheck, frontend tests =="
cat "$checks"
static=$(cat "$checks.rc")
rm -f "$checks" "$checks.rc"
if [ "$static" -ne 0 ]; then echo "make test: the static checks failed (see above)"; exit "$static"; fi
if [ "$tests" -ne 0 ]; then echo "make test: pytest failed (exit code $tests)"; exit "$tests"; fi
echo "make test: all passed"
