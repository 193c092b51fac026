"""The command that re-creates a result folder, printed in its report.

:func:`reproduce_command` (one recording) and :func:`campaign_reproduce_command` (a campaign)
rebuild the ``dampfit analyze`` (or ``dampfit demo``) command from summary.json: the input
paths, the mass, and every recorded option (``provenance.options``) as its flag, shell-quoted,
with the folder's absolute path as ``--out``. Values of the wrong type (an edited summary)
are left out, never passed on unquoted.

A folder that holds its own input — one ``dampfit record`` wrote (its marker kind is
``record``): recording.csv and its analysis side by side — cannot be re-created in place:
``dampfit analyze`` refuses an ``--out`` that holds its input, and replacing the folder would
lose the recording. Its command re-analyses the recording into a new folder beside it
(:func:`reanalysis_folder`), and the report says so.
"""

from __future__ import annotations

import math
import os
import shlex
from pathlib import Path

from dampfit._options import DEFAULT_MAX_STEPS
from dampfit.files.folder import DEMO_MARKER, read_marker
from dampfit.output.document import Block
from dampfit.output.report.values import finite, get


def is_demo(s: dict, directory: Path) -> bool:
    """Whether ``directory`` is a folder ``dampfit demo`` wrote (its truth file is there)."""
    path = get(s, "input", "path")
    return (directory / DEMO_MARKER).is_file() and isinstance(path, str) \
        and Path(path).name == DEMO_MARKER.replace(".truth.json", ".csv")


def _mass_flags(m) -> list[str]:
    """``--mass KG [--mass-sd KG]`` of a summary's mass entry (nothing if there is no mass)."""
    if not (isinstance(m, dict) and finite(m.get("value"))):
        return []
    parts = ["--mass", repr(float(m["value"]))]
    if finite(m.get("sd")) and m["sd"] > 0:
        parts += ["--mass-sd", repr(float(m["sd"]))]
    return parts


def _signal_flags(opts: dict) -> list[str]:
    """``--axis``, ``--window`` and ``--band`` as the recorded options gave them."""
    parts = []
    if isinstance(opts.get("axis"), str) and opts["axis"] != "auto":
        parts += ["--axis", shlex.quote(opts["axis"])]
    for key in ("window", "band"):
        v = opts.get(key)
        if isinstance(v, list) and len(v) == 2 and all(finite(x) for x in v):
            parts += [f"--{key}", repr(float(v[0])), repr(float(v[1]))]
    return parts


def _whole(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 1


def _modes_flags(opts: dict) -> list[str]:
    """``--max-modes N`` (N > 1) and ``--mode-of-mass N`` as recorded; other values (an edited
    summary) are left out."""
    parts = []
    if _whole(opts.get("max_modes")) and opts["max_modes"] > 1:
        parts += ["--max-modes", str(opts["max_modes"])]
    if _whole(opts.get("mode_of_mass")):
        parts += ["--mode-of-mass", str(opts["mode_of_mass"])]
    return parts


#: The reading options recorded in ``provenance.options`` (:data:`dampfit.io.readers.READ_OPTIONS`)
#: and what each value may be to become a flag again.
_READ_FLAGS = {"time_column": "one", "accel_columns": "many", "time_unit": "one",
               "accel_unit": "one", "sheet": "one", "variable": "one", "row": "int", "run": "one",
               "rate": "number", "group": "one", "channel": "one"}


def _flag(flag: str, value: str) -> list[str]:
    """``--flag VALUE``, or ``--flag=VALUE`` when the value starts with ``-`` (else the
    parser would take it for an option), shell-quoted."""
    if value.startswith("-"):
        return [shlex.quote(f"{flag}={value}")]
    return [flag, shlex.quote(value)]


def _read_flags(opts: dict) -> list[str]:
    """The reading options (``--time-column`` … ``--run``) as the recorded options gave them;
    values of the wrong type (an edited summary) are left out."""
    parts: list[str] = []
    for key, kind in _READ_FLAGS.items():
        v = opts.get(key)
        flag = "--" + key.replace("_", "-")
        if kind == "int" and isinstance(v, int) and not isinstance(v, bool) and v >= 0:
            parts += [flag, str(v)]
        elif kind == "number" and isinstance(v, (int, float)) and not isinstance(v, bool) \
                and math.isfinite(v) and v > 0:
            parts += [flag, repr(float(v))]
        elif kind == "one" and isinstance(v, (str, int)) and not isinstance(v, bool):
            parts += _flag(flag, str(v))
        elif kind == "many" and isinstance(v, list) and v and all(
                isinstance(x, (str, int)) and not isinstance(x, bool) for x in v):
            values = [str(x) for x in v]
            if len(values) == 1:
                parts += _flag(flag, values[0])
            else:  # several values cannot take the --flag=VALUE form; a leading '-' stays
                parts += [flag] + [shlex.quote(x) for x in values]
    return parts


def _input_arg(path) -> str:
    """The input path as a shell word; a relative path starting with ``-`` gets ``./``."""
    if not isinstance(path, str):
        return "FILE"
    return shlex.quote("./" + path if path.startswith("-") else path)


def reproduce_command(s: dict, directory: str | os.PathLike) -> str:
    """The shell command that re-creates the result folder ``directory`` from its input.

    A folder that holds its own input (:func:`own_input`: one ``dampfit record`` wrote) cannot
    be re-created in place: the command re-analyses that input into :func:`reanalysis_folder`
    instead."""
    directory = Path(os.path.abspath(directory))
    q = shlex.quote
    seed = get(s, "provenance", "seed")
    seed = seed if isinstance(seed, int) else 0
    if is_demo(s, directory):
        return f"dampfit demo --seed {seed} --out {q(str(directory))}"
    opts = get(s, "provenance", "options")
    opts = opts if isinstance(opts, dict) else {}
    own = own_input(s, directory)
    path = str(own) if own is not None else get(s, "input", "path")
    parts = ["dampfit", "analyze", _input_arg(path)]
    parts += _mass_flags(s.get("mass")) + _signal_flags(opts) + _read_flags(opts)
    parts += _modes_flags(opts)
    if isinstance(opts.get("model"), str) and opts["model"] != "auto":
        parts += ["--model", q(opts["model"])]
    if finite(opts.get("amplitude")):
        parts += ["--amplitude", repr(float(opts["amplitude"]))]
    if isinstance(opts.get("max_steps"), int) and opts["max_steps"] != DEFAULT_MAX_STEPS:
        parts += ["--max-steps", str(opts["max_steps"])]
    out = directory if own is None else reanalysis_folder(directory)
    return " ".join(parts + ["--seed", str(seed), "--out", q(str(out))])


def reproduce_blocks(s: dict, directory: Path) -> list[Block]:
    """The "re-create this folder" paragraph and command of a single-recording report."""
    path = get(s, "input", "path")
    if own_input(s, directory) is not None:
        record = _is_record(directory)
        intro = ("This folder holds its own " + ("recording (dampfit record wrote it)" if record
                                                 else "input file")
                 + ", and dampfit analyze never writes into the folder that holds its input: "
                 "this command re-runs the analysis of that file into a new folder beside this "
                 "one (add --force to replace that folder" + ("; to record anew, run dampfit "
                                                              "record URL --out DIR" if record
                                                              else "") + "):")
    else:
        intro = ("Re-create this folder from the input file (sha256 above; add --force to "
                 "replace the folder):")
    out: list[Block] = [("p", [intro]), ("code", reproduce_command(s, directory))]
    if isinstance(path, str) and not os.path.isabs(path):
        out.append(("p", [f"The input path {path} was recorded relative to the folder the "
                          "analysis ran in: run the command from there."]))
    return out


def own_input(s: dict, directory: str | os.PathLike) -> Path | None:
    """The recording ``directory`` holds itself, or None.

    A folder ``dampfit record`` wrote (marker kind ``record``, :func:`dampfit.files.folder.
    read_marker`) holds the recording it analysed: ``DIR/<name of the input file>``, wherever
    the folder has been moved since. Any other folder holds its input when the summary's
    (absolute) input path lies inside it. Such a folder cannot be re-created in place —
    ``dampfit analyze`` refuses an ``--out`` that holds its input, and replacing a record
    folder would lose the recording."""
    directory = Path(os.path.abspath(directory))
    if is_demo(s, directory):  # dampfit demo simulates its recording again: no input to keep
        return None
    path = get(s, "input", "path")
    if not isinstance(path, str) or not path:
        path = None
    if _is_record(directory):
        name = Path(path).name if path else ""
        return directory / (name if name not in ("", ".", "..") else RECORDING)
    return Path(path) if path and _inside(path, directory) else None


def _is_record(directory: Path) -> bool:
    """Whether ``dampfit record`` wrote ``directory`` (its marker's kind)."""
    marker = read_marker(directory)
    return isinstance(marker, dict) and marker.get("kind") == "record"


#: The file a ``dampfit record`` folder keeps its recording in (:data:`dampfit.record.session.CSV`).
RECORDING = "recording.csv"


def _inside(path: str, directory: Path) -> bool:
    """Whether the absolute ``path`` is ``directory`` or lies inside it (as given, and with
    links resolved)."""
    if not os.path.isabs(path):  # relative to a folder the report does not know
        return False
    p = Path(os.path.abspath(path))
    pairs = [(p, directory)]
    try:  # an edited summary may hold a path no system call takes (a NUL byte)
        pairs.append((Path(os.path.realpath(p)), Path(os.path.realpath(directory))))
    except (OSError, ValueError):
        pass
    return any(file == folder or folder in file.parents for file, folder in pairs)


def reanalysis_folder(directory: str | os.PathLike) -> Path:
    """Where the command of a folder that holds its own input writes: ``DIR.reanalysed``,
    beside ``DIR``."""
    directory = Path(os.path.abspath(directory))
    return directory.parent / f"{directory.name}.reanalysed"


def _hint(what: str, s: dict, directory: Path) -> str:
    """The command that computes an optional section that is absent."""
    if what == "verification":
        return f"dampfit verify {shlex.quote(os.path.abspath(directory))}"
    cmd = reproduce_command(s, directory)
    if what == "model_checks" and " --model " not in cmd and not cmd.startswith("dampfit demo"):
        cmd = cmd.replace(" --seed ", " --model auto --seed ", 1)
    return cmd + " --force"


def not_computed(what: str, s: dict, directory: Path) -> list[Block]:
    """That an optional section is absent, and the command that computes it."""
    return [("p", [f"Not computed ({what} is absent from this result folder). To compute it, run:"]),
            ("code", _hint(what, s, directory))]


def campaign_reproduce_command(s: dict, directory: str | os.PathLike) -> str:
    """The shell command that re-creates the campaign folder ``directory`` from its inputs
    (into :func:`reanalysis_folder` if the folder holds one of them)."""
    directory = Path(os.path.abspath(directory))
    q = shlex.quote
    tests = [t for t in (s.get("tests") or []) if isinstance(t, dict)]
    paths = [get(t, "input", "path") for t in tests]
    parts = ["dampfit", "analyze"] + [_input_arg(p) for p in paths]
    am = get(s, "design", "added_mass")
    m = get(s, "design", "mass")
    if isinstance(am, dict) and isinstance(am.get("values"), list):
        parts += ["--added-mass"] + [repr(float(v)) if finite(v) else "KG" for v in am["values"]]
        if finite(am.get("sd")) and am["sd"] > 0:
            parts += ["--added-mass-sd", repr(float(am["sd"]))]
    else:
        parts += _mass_flags(m)
    opts = get(s, "provenance", "options")
    opts = opts if isinstance(opts, dict) else {}
    parts += _signal_flags(opts) + _read_flags(opts) + _modes_flags(opts)
    seed = get(s, "provenance", "seed")
    seed = seed if isinstance(seed, int) and not isinstance(seed, bool) else 0
    inside = any(isinstance(p, str) and _inside(p, directory) for p in paths)
    out = reanalysis_folder(directory) if inside else directory
    return " ".join(parts + ["--seed", str(seed), "--out", q(str(out))])
