"""Robustness sweeps: a `footfall/sweep@1` spec expands into cases, each one headless run, run on worker processes
(`local`) or a Ray cluster (`ray`), stored per case so a sweep resumes, and summarized as success rates per cell
with 95 % intervals (table, JSON, CSV, heat map PNG)."""

from planning.sweep.backends import LocalBackend, RayBackend, make_backend
from planning.sweep.cases import case_key, code_version, expand, run_case
from planning.sweep.runner import Progress, ResultStore, run_sweep
from planning.sweep.spec import FORMAT, SweepSpec, SweepSpecError, load_spec, parse_spec, sweep_json_schema
from planning.sweep.summary import format_table, summarize, wilson

__all__ = [
    "FORMAT",
    "LocalBackend",
    "Progress",
    "RayBackend",
    "ResultStore",
    "SweepSpec",
    "SweepSpecError",
    "case_key",
    "code_version",
    "expand",
    "format_table",
    "load_spec",
    "make_backend",
    "parse_spec",
    "run_case",
    "run_sweep",
    "summarize",
    "sweep_json_schema",
    "wilson",
]
