"""Record what Storm answers on the shared benchmark models, as reference data for posgmc's tests.

Run it with the reference environment (stormpy 2.0.0 + paynt 0.5.0), never with posgmc's:

    $POSGMC_REFERENCE_PYTHON benchmarks/storm_reference.py        # from the checkout's root

It finds every model under the benchmarks folder (PRISM-language files and explicit DRN files),
builds each one (once per set of constants) with Storm, records the sizes, and checks every property
of the accompanying property files with Storm's default environment and with its sound environment,
fully observably (POMDPs with ``force_fully_observable``; POSMG DRNs as plain SMGs). Each model is
handled in a child process so that a crash inside Storm (e.g. a bus error) loses one model only.
The result is written as JSON (sorted keys, indent 1, floats via ``repr``, infinities as the
strings ``"inf"`` and ``"-inf"``) to ``tests/data/storm_reference.json``; what every field means is
written into the JSON header (``header.fields``, ``header.notes``).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import importlib.metadata
import itertools
import json
import math
import platform
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from _locations import ROOT, shared_benchmarks  # this folder is on sys.path

HERE = Path(__file__).resolve().parent
DEFAULT_BENCHMARKS = shared_benchmarks()
DEFAULT_OUTPUT = HERE.parent / "tests" / "data" / "storm_reference.json"

MODEL_SUFFIXES = (".prism", ".templ", ".nm", ".smg")

# Constants the benchmarks README (and scale/README.md) prescribes for models whose constants are
# left undefined and that have no PRISM-games ``.args`` file; each string is one build.
MODEL_CONSTANTS: Mapping[str, tuple[str, ...]] = {
    "smg/dice/dice.prism": ("N=3",),
    "scale/two_robots.nm": ("N=10", "N=20"),
    "scale/pursuit.smg": ("N=6", "N=16"),
}

# Models without a property file: their properties are listed in scale/README.md.
README_PROPERTIES: Mapping[str, tuple[str, ...]] = {
    "scale/two_robots.nm": ('Pmax=? [ F "goal" ]', 'Rmin=? [ F "goal" ]'),
    "scale/pursuit.smg": ('<<evader>> Pmax=? [ F "escaped" ]',),
}
README_PROPERTIES_SOURCE = "scale/README.md"

NO_RESULT = "Storm returned no result (formula unsupported for this model type)"

# Property files written for PRISM-games number players from 1; Storm numbers them from 0. Their
# numeric coalitions are given to Storm as player names (which mean the same in both tools).
PRISM_GAMES_PREFIX = "smg/"

# Directory-level property files of posmg/prism-models (PAYNT's, in Storm numbering as written).
DIRECTORY_PROPERTY_FILES: Mapping[str, tuple[str, ...]] = {
    "posmg/prism-models": ("pmax.props", "pmin.props"),
}


@dataclasses.dataclass(frozen=True)
class PropertyStatement:
    """One property of a property file.

    Attributes:
        source: Where the text comes from (path relative to the benchmarks folder).
        line: 1-based line of the text in ``source`` (0 for README-listed properties).
        text: The property exactly as written in ``source``.
        storm_text: The property exactly as given to Storm.
    """

    source: str
    line: int
    text: str
    storm_text: str


@dataclasses.dataclass(frozen=True)
class Job:
    """One model build (one file, one set of model constants) and its properties.

    Attributes:
        benchmarks: The benchmarks folder.
        file: Model path relative to ``benchmarks``.
        fmt: ``"prism"`` or ``"drn"``.
        constants: Storm constant definitions for the model, e.g. ``"N=10"`` ('' for none).
        constants_source: Where ``constants`` come from.
        declarations: Property-file constant declarations (e.g. ``"const int k"``).
        property_constants: Values to sweep each declared property constant over.
        properties: The properties to check.
    """

    benchmarks: str
    file: str
    fmt: str
    constants: str
    constants_source: str
    declarations: tuple[str, ...]
    property_constants: tuple[tuple[str, tuple[int, ...]], ...]
    properties: tuple[PropertyStatement, ...]

    def to_json(self) -> str:
        """Serialise for the child process.

        Returns:
            The job as a JSON string.
        """
        return json.dumps(dataclasses.asdict(self))

    @staticmethod
    def from_json(text: str) -> Job:
        """Inverse of :meth:`to_json`.

        Args:
            text: A string produced by :meth:`to_json`.

        Returns:
            The job.
        """
        raw = json.loads(text)
        return Job(
            benchmarks=raw["benchmarks"],
            file=raw["file"],
            fmt=raw["fmt"],
            constants=raw["constants"],
            constants_source=raw["constants_source"],
            declarations=tuple(raw["declarations"]),
            property_constants=tuple((n, tuple(v)) for n, v in raw["property_constants"]),
            properties=tuple(PropertyStatement(**p) for p in raw["properties"]),
        )


# ----------------------------------------------------------------------------------------------
# Discovery (parent process; no Storm needed)
# ----------------------------------------------------------------------------------------------


def is_drn(path: Path) -> bool:
    """Tell whether a model file is in Storm's explicit DRN format.

    Args:
        path: The model file.

    Returns:
        True if a line starts with ``@type:``.
    """
    with path.open() as handle:
        return any(line.startswith("@type:") for line in handle)


def property_files(benchmarks: Path, model: Path) -> list[Path]:
    """The property files that belong to a model file.

    ``sketch.templ`` and ``model.prism`` go with ``sketch.props`` (and the derived
    ``sketch.opt.props``);
    ``X.prism`` goes with ``X.prism*.props``, ``X.props`` and the derived ``X.storm.props``;
    ``posmg/prism-models/*.prism`` go with that folder's ``pmax.props`` and ``pmin.props``.

    Args:
        benchmarks: The benchmarks folder.
        model: The model file.

    Returns:
        The existing property files, sorted by name.
    """
    folder = model.parent
    relative_folder = folder.relative_to(benchmarks).as_posix()
    names: set[str] = set()
    if model.name in ("sketch.templ", "model.prism"):
        names.update({"sketch.props", "sketch.opt.props"})
    else:
        stem = model.name.rsplit(".", 1)[0]
        names.update({f"{stem}.props", f"{stem}.storm.props"})
        names.update(p.name for p in folder.glob(f"{model.name}*.props"))
    names.update(DIRECTORY_PROPERTY_FILES.get(relative_folder, ()))
    return sorted(folder / name for name in names if (folder / name).is_file())


def args_constants(args_file: Path) -> dict[str, tuple[int, ...]]:
    """Read the ``-const`` option of a PRISM-games ``.args`` file (first line that has one).

    Args:
        args_file: The ``.args`` file.

    Returns:
        Constant name -> values; ``a:b`` and ``a:step:b`` ranges are expanded (integers only).
    """
    for line in args_file.read_text().splitlines():
        tokens = line.split()
        if "-const" not in tokens:
            continue
        definitions = tokens[tokens.index("-const") + 1]
        result: dict[str, tuple[int, ...]] = {}
        for definition in definitions.split(","):
            name, value = definition.split("=")
            parts = [int(x) for x in value.split(":")]
            if len(parts) == 1:
                result[name] = (parts[0],)
            elif len(parts) == 2:
                result[name] = tuple(range(parts[0], parts[1] + 1))
            else:
                result[name] = tuple(range(parts[0], parts[2] + 1, parts[1]))
        return result
    return {}


def players_of(model_text: str) -> list[str]:
    """Player names of a PRISM-games model in declaration order.

    Args:
        model_text: The model's text.

    Returns:
        The names.
    """
    return re.findall(r"^\s*player\s+(\w+)", model_text, flags=re.MULTILINE)


def numeric_coalitions_to_names(text: str, players: Sequence[str]) -> str:
    """Rewrite 1-based numeric coalitions (PRISM-games) as player names.

    Args:
        text: A property.
        players: Player names in declaration order.

    Returns:
        The property with ``<<1,2>>`` replaced by ``<<p1,p2>>`` (``<<*>>`` and names left alone).
    """

    def replace(match: re.Match[str]) -> str:
        indices = [int(x) for x in match.group(1).split(",")]
        if any(i < 1 or i > len(players) for i in indices):
            return match.group(0)
        return "<<" + ",".join(players[i - 1] for i in indices) + ">>"

    return re.sub(r"<<\s*(\d+(?:\s*,\s*\d+)*)\s*>>", lambda m: replace(m), text)


def read_property_file(
    path: Path, benchmarks: Path, players: Sequence[str]
) -> tuple[list[str], list[PropertyStatement]]:
    """Split a property file into constant declarations and properties.

    Args:
        path: The property file.
        benchmarks: The benchmarks folder.
        players: Player names (for rewriting PRISM-games numeric coalitions).

    Returns:
        (declarations such as ``const int k``, properties).
    """
    source = path.relative_to(benchmarks).as_posix()
    translate = source.startswith(PRISM_GAMES_PREFIX)
    declarations: list[str] = []
    statements: list[PropertyStatement] = []
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        code = line.split("//", 1)[0]
        for piece in code.split(";"):
            text = piece.strip()
            if not text:
                continue
            if re.match(r"const\b", text):
                declarations.append(text)
                continue
            storm_text = numeric_coalitions_to_names(text, players) if translate else text
            statements.append(PropertyStatement(source, number, text, storm_text))
    return declarations, statements


def discover(benchmarks: Path) -> list[Job]:
    """List the jobs for every model file under the benchmarks folder.

    Args:
        benchmarks: The benchmarks folder.

    Returns:
        Jobs sorted by file and constants.
    """
    jobs: list[Job] = []
    models = sorted(p for p in benchmarks.rglob("*") if p.is_file() and p.suffix in MODEL_SUFFIXES)
    for model in models:
        relative = model.relative_to(benchmarks).as_posix()
        text = model.read_text()
        players = players_of(text)
        declarations: list[str] = []
        properties: list[PropertyStatement] = []
        property_constants: dict[str, tuple[int, ...]] = {}
        for props in property_files(benchmarks, model):
            found_declarations, found = read_property_file(props, benchmarks, players)
            declarations.extend(d for d in found_declarations if d not in declarations)
            properties.extend(found)
            args = props.with_name(props.name + ".args")
            if args.is_file():
                property_constants.update(args_constants(args))
        for text_ in README_PROPERTIES.get(relative, ()):
            properties.append(PropertyStatement(README_PROPERTIES_SOURCE, 0, text_, text_))
        constant_sets = [(c, "benchmarks README") for c in MODEL_CONSTANTS.get(relative, ())]
        model_args = model.with_name(model.name + ".args")
        if model_args.is_file():
            values = args_constants(model_args)
            names = sorted(values)
            for combination in itertools.product(*(values[n] for n in names)):
                definition = ",".join(f"{n}={v}" for n, v in zip(names, combination))
                constant_sets.append((definition, model_args.relative_to(benchmarks).as_posix()))
        if not constant_sets:
            constant_sets = [("", "")]
        for constants, constants_source in constant_sets:
            jobs.append(
                Job(
                    benchmarks=str(benchmarks),
                    file=relative,
                    fmt="drn" if is_drn(model) else "prism",
                    constants=constants,
                    constants_source=constants_source,
                    declarations=tuple(declarations),
                    property_constants=tuple(sorted(property_constants.items())),
                    properties=tuple(properties),
                )
            )
    return jobs


# ----------------------------------------------------------------------------------------------
# One job (child process; imports Storm)
# ----------------------------------------------------------------------------------------------


def plain(value: Any) -> Any:
    """Turn a Storm value into a JSON-friendly one.

    Args:
        value: A float, bool or number-like value.

    Returns:
        bool stays bool; floats stay floats; infinities become ``"inf"``/``"-inf"``, NaN ``"nan"``.
    """
    if isinstance(value, bool):
        return value
    number = float(value)
    if math.isnan(number):
        return "nan"
    if math.isinf(number):
        return "inf" if number > 0 else "-inf"
    return number


def one_line(message: str) -> str:
    """Shorten an exception message to one line.

    Args:
        message: Any text.

    Returns:
        The text with whitespace runs collapsed, at most 400 characters.
    """
    flat = " ".join(message.split())
    return flat if len(flat) <= 400 else flat[:397] + "..."


def check_once(stormpy: Any, payntbind: Any, model: Any, kind: str, prop: Any, env: Any) -> Any:
    """Check one property on one model with one environment.

    Args:
        stormpy: The stormpy module.
        payntbind: The payntbind module.
        model: The built sparse model.
        kind: ``"SMG"``, ``"POSMG"``, ``"POMDP"`` or another Storm model type name.
        prop: A parsed Storm property.
        env: A Storm environment.

    Returns:
        The check result (possibly None when Storm has none).
    """
    if kind in ("SMG", "POSMG"):
        # stormpy 2.0.0's model_checking returns None on games; payntbind has Storm's game checker.
        return payntbind.synthesis.model_check_smg(model, prop.get_raw_formula(), False, False, env)
    partial = kind == "POMDP"
    return stormpy.model_checking(model, prop, force_fully_observable=partial, environment=env)


def result_value(result: Any, state: int) -> tuple[Any, list[Any] | None]:
    """Value (and sound bounds, if Storm gives them) of a result at a state.

    Args:
        result: A Storm check result.
        state: The state.

    Returns:
        (value, [lower, upper] or None).
    """
    if result.is_qualitative():
        return bool(result[state]), None
    bounded = result[state]
    bounds = None
    if bounded.has_lower and bounded.has_upper:
        bounds = [plain(bounded.lower), plain(bounded.upper)]
    return plain(result.get_value(state)), bounds


def load(job: Job, record: dict[str, Any]) -> tuple[Any, Any, str]:
    """Read a job's model: a PRISM program to build later, or an explicit model built now.

    Args:
        job: The job.
        record: The model's record; ``build``/``message`` are set when the model cannot be read.

    Returns:
        (program or None, model or None, kind); (None, None, "") when the model cannot be read.
    """
    import stormpy

    path = Path(job.benchmarks) / job.file
    try:
        if job.fmt == "drn":
            with path.open() as handle:
                lines = (line for line in handle if line.startswith("@type:"))
                drn_type = next(lines).split(":", 1)[1].strip()
            if drn_type == "POSMG":
                # Storm's DRN parser has no POSMG type; read it the way PAYNT does (a POMDP plus
                # per-state players), on a private copy as PAYNT writes a scratch file beside it.
                from paynt.parser.drn_parser import DrnParser

                with tempfile.TemporaryDirectory() as scratch:
                    copy = Path(scratch) / "model.drn"
                    shutil.copyfile(path, copy)
                    return None, DrnParser.parse_drn(str(copy)), "POSMG"
            options = stormpy.io.DirectEncodingParserOptions()
            options.build_choice_labeling = True
            model = stormpy.build_model_from_drn(str(path), options=options)
            return None, model, str(model.model_type).rsplit(".", 1)[-1]
        program = stormpy.parse_prism_program(str(path))
        if job.constants:
            program, _ = stormpy.instantiate_constants(program, job.constants)
        if program.has_undefined_constants:
            undefined = ", ".join(c.name for c in program.constants if not c.defined)
            record["build"] = "error"
            record["message"] = f"undefined constants: {undefined} (no values known)"
            return None, None, ""
        # Declared once per program: Storm refuses to declare a property constant twice.
        for declaration in job.declarations:
            stormpy.parse_properties(declaration + ";", program)
        return program, None, ""
    except Exception as error:  # Storm raises RuntimeError subclasses with its own message
        record["build"] = "parse error"
        record["message"] = one_line(str(error))
        return None, None, ""


Entry = dict[str, Any]


def parse_all(job: Job, program: Any) -> tuple[list[Entry], list[tuple[Entry, Any]]]:
    """Parse each property on its own, so that one bad property does not hide the others.

    Property constants (smg_example's ``k``) give one entry per value when the property uses them.

    Args:
        job: The job.
        program: The PRISM program (None for DRN models).

    Returns:
        (all entries, (entry, parsed property) pairs to check).
    """
    import stormpy

    entries: list[dict[str, Any]] = []
    checks: list[tuple[dict[str, Any], Any]] = []
    names = [name for name, _ in job.property_constants]
    value_lists = [values for _, values in job.property_constants]
    sweep = [dict(zip(names, values)) for values in itertools.product(*value_lists)]
    for statement in job.properties:
        entry: dict[str, Any] = {
            "props_file": statement.source,
            "line": statement.line,
            "text": statement.text,
            "storm_text": statement.storm_text,
        }
        try:
            if program is None:
                found = stormpy.parse_properties(statement.storm_text)
            else:
                found = stormpy.parse_properties(statement.storm_text, program)
            if len(found) != 1:
                raise RuntimeError(f"Storm read {len(found)} properties from this text")
        except Exception as error:
            entry["storm"] = "parse error"
            entry["message"] = one_line(str(error))
            entries.append(entry)
            continue
        prop = found[0]
        instances = []
        if sweep and program is not None:
            for assignment in sweep:
                _, instantiated = stormpy.instantiate_constants(program, assignment, [prop])
                instances.append((assignment, instantiated[0]))
        if all(str(p.get_raw_formula()) == str(prop.get_raw_formula()) for _, p in instances):
            entries.append(entry)
            checks.append((entry, prop))
            continue
        for assignment, instance in instances:
            copy = {**entry, "property_constants": assignment}
            entries.append(copy)
            checks.append((copy, instance))
    return entries, checks


def build(program: Any, formulas: list[Any]) -> tuple[Any, str]:
    """Build the whole model of a PRISM program so that the given formulas can be checked on it.

    Args:
        program: The PRISM program (constants instantiated).
        formulas: Parsed properties (their atomic expressions become labels).

    Returns:
        (model, Storm's model type name).
    """
    import stormpy

    # With exactly one formula Storm makes its target states absorbing while building (fewer
    # transitions than the model has); with two or more it does not, so a lone formula goes twice.
    # Observation valuations stay off: Storm refuses them when an observable is named like a
    # formula (drone-4-1), and checking does not need them.
    options = stormpy.BuilderOptions(formulas * 2 if len(formulas) == 1 else formulas)
    options.set_build_all_labels()
    options.set_build_all_reward_models()
    options.set_build_observation_valuations(False)
    model = stormpy.build_model(program, options=options)
    return model, str(model.model_type).rsplit(".", 1)[-1]


def describe(model: Any, kind: str, record: dict[str, Any]) -> None:
    """Write a built model's sizes into its record.

    Args:
        model: The built model.
        kind: Its kind (Storm's model type name, or POSMG).
        record: The record to fill.
    """
    record["build"] = "ok"
    record["model_type"] = kind
    record["states"] = model.nr_states
    record["choices"] = model.nr_choices
    record["transitions"] = model.nr_transitions
    record["initial_states"] = len(model.initial_states)
    record["reward_models"] = sorted(model.reward_models.keys())
    if kind == "POMDP":
        record["observations"] = model.nr_observations
        record["checked_as"] = "MDP (force_fully_observable=True: fully observable value)"
    if kind == "POSMG":
        record["observations"] = len(set(model.get_observations()))
        record["player0_observations"] = model.get_p0_observation_count()
        record["checked_as"] = "SMG (observations ignored: fully observable value)"


def check_all(model: Any, kind: str, checks: list[tuple[dict[str, Any], Any]]) -> None:
    """Check every property with the default and the sound environment; fill the entries.

    Args:
        model: The built model.
        kind: Its kind (Storm's model type name, or POSMG).
        checks: (entry, parsed property) pairs.
    """
    import payntbind
    import stormpy
    import stormpy.environments

    environments = {"default": stormpy.Environment, "sound": stormpy.environments.sound}
    initial = model.initial_states[0]
    for entry, prop in checks:
        entry["formula"] = str(prop.get_raw_formula())
        for name, make in environments.items():
            try:
                result = check_once(stormpy, payntbind, model, kind, prop, make())
                if result is None:
                    raise RuntimeError(NO_RESULT)
                value, bounds = result_value(result, initial)
            except Exception as error:
                if name == "default":
                    entry["storm"] = "no result"
                    entry["message"] = one_line(str(error))
                    break
                entry["sound_error"] = one_line(str(error))
                continue
            entry["storm"] = "ok"
            entry[name] = value
            if bounds is not None and name == "sound":
                entry["sound_bounds"] = bounds


def run_job(job: Job) -> dict[str, Any]:
    """Build one model and check its properties.

    Args:
        job: The job.

    Returns:
        The model's JSON record (see the header's ``fields``).
    """
    record: dict[str, Any] = {"file": job.file, "format": job.fmt, "constants": {}}
    if job.constants:
        pairs = (d.split("=") for d in job.constants.split(","))
        record["constants"] = {k: int(v) if re.fullmatch(r"-?\d+", v) else v for k, v in pairs}
        record["constants_source"] = job.constants_source
    program, model, kind = load(job, record)
    if program is None and model is None:
        record["properties"] = [
            {
                "props_file": statement.source,
                "line": statement.line,
                "text": statement.text,
                "storm_text": statement.storm_text,
                "storm": "no result",
                "message": "model not built (see the model's message)",
            }
            for statement in job.properties
        ]
        return record
    entries, checks = parse_all(job, program)
    record["properties"] = sorted(entries, key=entry_order)
    if program is not None:
        try:
            model, kind = build(program, [p for _, p in checks])
        except Exception as error:
            record["build"] = "error"
            record["message"] = one_line(str(error))
            for entry, _ in checks:
                entry["storm"] = "no result"
                entry["message"] = "model not built (see the model's message)"
            return record
    describe(model, kind, record)
    check_all(model, kind, checks)
    return record


def entry_order(entry: Mapping[str, Any]) -> tuple[str, int, str]:
    """Sort key of a property entry: file order, then property-constant values.

    Args:
        entry: A property entry.

    Returns:
        The key.
    """
    constants = json.dumps(entry.get("property_constants", {}), sort_keys=True)
    return (entry["props_file"], entry["line"], constants)


# ----------------------------------------------------------------------------------------------
# Driver
# ----------------------------------------------------------------------------------------------


def run_in_child(job: Job, timeout: float) -> dict[str, Any]:
    """Run one job in a child process.

    Args:
        job: The job.
        timeout: Seconds before the child is stopped.

    Returns:
        The child's record, or a record saying how the child died.
    """
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "record.json"
        script = str(Path(__file__).resolve())
        command = [sys.executable, script, "--job", job.to_json(), "--job-output", str(out)]
        try:
            finished = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            message = f"timeout after {timeout:g} s"
            return {"file": job.file, "format": job.fmt, "constants": {}, "build": "error",
                    "message": message}
        if out.is_file():
            return json.loads(out.read_text())
        tail = one_line((finished.stderr or "")[-300:] + " " + (finished.stdout or "")[-300:])
        return {
            "file": job.file,
            "format": job.fmt,
            "constants": {},
            "build": "error",
            "message": f"Storm process died (exit code {finished.returncode}): {tail}",
        }


def to_plain_json(value: Any) -> Any:
    """Replace non-finite floats anywhere in a JSON tree by strings.

    Args:
        value: A JSON tree.

    Returns:
        The same tree with inf/-inf/nan as strings.
    """
    if isinstance(value, float) and not math.isfinite(value):
        return plain(value)
    if isinstance(value, dict):
        return {k: to_plain_json(v) for k, v in value.items()}
    if isinstance(value, list):
        return [to_plain_json(v) for v in value]
    return value


FIELDS = {
    "models[]": "one entry per model file and set of model constants, sorted by file, constants",
    "file": "model path relative to the benchmarks folder",
    "format": "prism (PRISM language) or drn (explicit; POSMG DRNs read as PAYNT does)",
    "constants": "model constants used for this build ({} if none)",
    "constants_source": "where the constants come from",
    "build": "ok, parse error, or error (then message says why)",
    "model_type": "Storm's model type (DTMC, MDP, POMDP, SMG) or POSMG for PAYNT's POSMG DRNs",
    "states/choices/transitions": "sizes of the whole model as built by Storm "
    "(no property-based absorbing states)",
    "initial_states": "number of initial states (values are at the first one)",
    "observations": "POMDP: Storm's observation count; POSMG: distinct observation ids in the DRN",
    "player0_observations": "POSMG: observations of player 0's states "
    "(payntbind get_p0_observation_count)",
    "reward_models": "names of the reward models Storm built ('' = unnamed)",
    "checked_as": "how a partially observable model was checked (fully observably)",
    "properties[]": "one entry per property (per property-constant value if the property uses it)",
    "props_file/line": "where the property is written (line 0: listed in scale/README.md)",
    "text": "the property as written in props_file",
    "storm_text": "the property exactly as given to Storm (see header.coalitions)",
    "property_constants": "values of property-file constants (e.g. const int k) for this entry",
    "formula": "how Storm printed the parsed formula",
    "storm": "ok; parse error (Storm could not parse it); or no result (Storm parsed it but "
    "refused it or returned nothing)",
    "message": "Storm's message for parse error / no result",
    "default": "value at the initial state with stormpy.Environment(): Storm's built-in defaults "
    "(not sound, relative precision 1e-6). NB stormpy.model_checking without an environment "
    "uses environments.default(model), which is the sound one",
    "sound": "value at the initial state with stormpy.environments.sound()",
    "sound_bounds": "[lower, upper] Storm reports with the sound environment "
    "(absent when it gives none, e.g. for games)",
    "sound_error": "message when only the sound environment failed",
    "values": "floats; booleans for threshold properties; 'inf'/'-inf'/'nan' as strings",
}

GAMES = (
    "SMG and POSMG values come from "
    "payntbind.synthesis.model_check_smg(model, formula, False, False, env)"
)

COALITIONS = (
    "Storm numbers players from 0 (<<0>> = first declared player), PRISM-games from 1. "
    "Property files under smg/ are PRISM-games': their numeric coalitions were given to Storm "
    "as player names (see storm_text). posmg/prism-models/pmax.props and pmin.props (<<1>>) "
    "were given as written: in Storm that is the SECOND player"
)

NOTES = [
    "Compare posgmc against 'sound' (or 'sound_bounds'), not 'default': Storm's unsound "
    "default stops early, e.g. pomdp/query-s2 default 518.369 vs sound 518.404 "
    "(relative gap 7e-5).",
    "Games (SMG, POSMG) give the same value in both environments and no bounds: the "
    "environment passed to model_check_smg does not make Storm's game solver sound "
    "(smg_example <<p1>> Pmax=? [F c=2] = 0.9999999615566406 in both; PRISM-games RESULT 1.0). "
    "Allow about 1e-6 relative when comparing game values.",
    "Sizes are of the whole model. Storm, given a single property, makes its target states "
    "absorbing while building and may report fewer transitions (RESULTS.md did so: drone-4-1 "
    "6533, grid-large-10-5 758, maze-alex 169, refuel-06 998, rocks-12 39812); this script "
    "passes the formulas so that Storm does not.",
    "Storm 2.0.0 reads PRISM 'observables ... endobservables' blocks itself; model files are "
    "given to Storm unchanged.",
]


def _portable(path: Path) -> str:
    """``path`` relative to the checkout when it lies inside it (the JSON names no machine)."""
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else path.name


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point.

    Args:
        argv: Arguments (default: sys.argv[1:]).

    Returns:
        Exit code.
    """
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    parser.add_argument("--benchmarks", type=Path, default=DEFAULT_BENCHMARKS, help="benchmarks")
    parser.add_argument("--output", type=Path, default=DEFAULT_OUTPUT, help="JSON file to write")
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds per model build")
    parser.add_argument("--only", default="", help="only models whose path contains this text")
    parser.add_argument("--job", help=argparse.SUPPRESS)
    parser.add_argument("--job-output", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.job is not None:
        record = run_job(Job.from_json(args.job))
        Path(args.job_output).write_text(json.dumps(to_plain_json(record)))
        return 0

    benchmarks = args.benchmarks.resolve()
    jobs = [j for j in discover(benchmarks) if args.only in j.file]
    records = []
    for number, job in enumerate(jobs, start=1):
        print(f"[{number}/{len(jobs)}] {job.file} {job.constants}", file=sys.stderr, flush=True)
        records.append(run_in_child(job, args.timeout))
    records.sort(key=lambda r: (r["file"], json.dumps(r["constants"], sort_keys=True)))

    import stormpy.info

    header = {
        "command": shlex.join(["$POSGMC_REFERENCE_PYTHON", *sys.argv]),
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "benchmarks": _portable(benchmarks),
        "storm_version": stormpy.info.storm_version(),
        "storm_long_version": stormpy.info.storm_long_version(),
        "stormpy_version": importlib.metadata.version("stormpy"),
        "paynt_version": importlib.metadata.version("paynt"),
        "python": platform.python_version(),
        "games": GAMES,
        "coalitions": COALITIONS,
        "fields": FIELDS,
        "notes": NOTES,
    }
    document = {"header": header, "models": records}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(to_plain_json(document), sort_keys=True, indent=1, allow_nan=False)
    args.output.write_text(text + "\n")
    size = args.output.stat().st_size
    print(f"wrote {args.output} ({size} bytes, {len(records)} models)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
