"""The reference pages in docs/ against the command-line tool (NONHOLO_CLI, set by CTest) and the
sources they describe, so that a new key, status, option or default cannot go undocumented:

- every key of the summary line that representative runs print (scenes, orders, adaptive steps,
  RK4, ARKODE, DLA, the implicit form, 3-D bodies, forces, --error-estimate, batches), and every
  key RunSummary::fields() and BatchResult::line() can print, is in docs/reference/summary.md;
  so is every column of a batch table;
- every enumerator of core/include/nonholo/status.hpp is in docs/reference/statuses.md with its
  text, and the exit codes the page gives are those the command line returns;
- the --help blocks of docs/reference/cli.md are the program's, and every subcommand has one;
- the scene tables of docs/design.md (sections 5 and 10.4) are `nonholo list`: the same scenes,
  parameters and defaults.
"""
import math
import pathlib
import re

import pytest

from support import cli, read_csv, summary_of

ROOT = pathlib.Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
SUMMARY_MD = DOCS / "reference" / "summary.md"
STATUSES_MD = DOCS / "reference" / "statuses.md"
CLI_MD = DOCS / "reference" / "cli.md"
DESIGN_MD = DOCS / "design.md"


def sections(path):
    """{heading: text} of a Markdown page, split at its ## headings."""
    out, heading = {}, ""
    for line in path.read_text().splitlines():
        if line.startswith("## "):
            heading = line[3:].strip()
        out[heading] = out.get(heading, "") + line + "\n"
    return out


def first_cells(text):
    """The backticked names in the first cell of every table row of `text`."""
    names = set()
    for line in text.splitlines():
        if line.startswith("|") and not line.startswith("| ---"):
            names.update(re.findall(r"`([a-z_0-9]+)`", line.split("|")[1]))
    return names


def summary_keys_documented():
    parts = sections(SUMMARY_MD)
    line = first_cells("".join(text for heading, text in parts.items() if heading != "The batch table"))
    return line, first_cells(parts["The batch table"])


def keys_of(line):
    return [word.split("=", 1)[0] for word in line.split()]


# Cheap runs that together print every kind of key. Each: the arguments, and a key it must print
# (so that a run that stopped printing what it is here for is noticed).
RUNS = [
    (["run", "sleigh", "--t-end", "1"], "extent"),
    (["run", "particle", "--t-end", "0.5", "--restart", "0"], "parasitic_max"),
    (["run", "snakeboard", "--t-end", "0.5", "--set", "u_psi_amp=0.2"], "momentum_drift_max"),
    (["run", "sleigh_contact", "--t-end", "0.2"], "restarts"),
    (["run", "sleigh_chain", "--set", "bodies=5", "--set", "k=1", "--order", "4", "--t-end", "0.5"], "composition"),
    (["run", "sleigh", "--tol", "1e-6", "--order", "4", "--dt", "1", "--t-end", "2"], "adaptive_steps"),
    (["run", "sleigh", "--method", "rk4", "--project", "--t-end", "0.5"], "rhs_evals"),
    (["run", "sleigh", "--method", "arkode-dp5", "--t-end", "0.5", "--error-estimate"], "error_estimate"),
    (["run", "sleigh", "--method", "dla-midpoint", "--t-end", "0.5"], "factorizations"),
    (["run", "suslov", "--t-end", "0.5", "--rotation", "moser-veselov-f"], "legendre_iterations_max"),
    (["run", "chaplygin_ball", "--t-end", "0.5"], "momentum_drift_max"),
    (["run", "rolling_disk", "--t-end", "0.05"], "energy_balance_err_max"),
    (["run", "wheeled_train", "--set", "bodies=5", "--t-end", "0.5", "--error-estimate"], "stability_ratio"),
    (["run", str(ROOT / "examples/scenes/towed_pair.json"), "--t-end", "0.5", "--method", "rk4"], "work"),
]


@pytest.mark.parametrize("args,key", RUNS, ids=[" ".join(pathlib.Path(w).name for w in a[1:]) for a, _ in RUNS])
def test_every_key_a_run_prints_is_documented(args, key):
    documented, _ = summary_keys_documented()
    done = cli(*args)
    assert done.returncode == 0, done.stderr
    keys = keys_of(done.stdout.strip())
    assert key in keys, f"`nonholo {' '.join(args)}` no longer prints {key}: {done.stdout}"
    missing = [k for k in keys if k not in documented]
    assert not missing, f"summary keys not in docs/reference/summary.md: {missing}"


def test_every_key_a_batch_prints_and_every_column_of_its_table_are_documented(tmp_path):
    line_keys, columns = summary_keys_documented()
    for scene, extra in (("sleigh", ["--vary", "v0=0.5:1.5"]),
                         (str(ROOT / "examples/scenes/towed_pair.json"), ["--error-estimate"])):
        out = tmp_path / "batch.csv"
        done = cli("batch", scene, "--count", "3", "--t-end", "0.3", "--threads", "2", "--out", str(out), *extra)
        assert done.returncode == 0, done.stderr
        keys = keys_of(done.stdout.strip())
        assert {"trajectories", "threads", "failed"} <= set(keys)
        assert not [k for k in keys if k not in line_keys], keys
        header, rows = read_csv(out)
        assert len(rows) == 3
        placeholders = {"v0", "x", "y", "theta", "x0", "y0", "theta0"}  # the varied parameter, body 0's coordinates
        missing = [c for c in header if c not in columns and c not in placeholders]
        assert not missing, f"batch table columns not in docs/reference/summary.md: {missing}"


def source_keys():
    """Every key the summary line can have, read from the code that prints it."""
    run = (ROOT / "scenarios/src/output/summary_fields.cpp").read_text()
    body = run[run.index("RunSummary::fields() const"):run.index("std::string RunSummary::line() const")]
    keys = re.findall(r'\b(?:text|number|integer)\("([a-z_]+)"', body)
    batch = (ROOT / "scenarios/src/batch/batch.cpp").read_text()
    body = batch[batch.index("BatchResult::line() const"):]
    body = body[:body.index("\n}\n")]
    keys += re.findall(r'" ([a-z_]+)="', body)
    return keys


def test_every_key_the_code_can_print_is_documented():
    keys = source_keys()
    assert len(keys) >= 30 and "status" in keys and "ranks" in keys, "update source_keys(): " + str(keys)
    documented, _ = summary_keys_documented()
    missing = [k for k in keys if k not in documented]
    assert not missing, f"summary keys in scenarios/src/output/summary_fields.cpp or batch.cpp not in docs/reference/summary.md: {missing}"
    stale = sorted(documented - set(keys) - {"ok"})
    assert not stale, f"docs/reference/summary.md documents keys the code does not print: {stale}"


def statuses_in_code():
    """(enumerator, text) for every Status, from status.hpp and status.cpp."""
    header = (ROOT / "core/include/nonholo/status.hpp").read_text()
    body = header[header.index("enum class Status {"):]
    body = body[:body.index("};")]
    enumerators = re.findall(r"^\s*([A-Z][A-Za-z]+),", body, re.M)
    texts = dict(re.findall(r'case Status::([A-Za-z]+): return "([a-z-]+)";', (ROOT / "core/src/base/status.cpp").read_text()))
    return [(e, texts.get(e)) for e in enumerators]


def status_table():
    """{text: (enumerator, exit column)} from the table of docs/reference/statuses.md."""
    rows = {}
    for line in sections(STATUSES_MD)["Every status"].splitlines():
        m = re.match(r"\| `([a-z-]+)` \| `([A-Za-z]+)` \| ([^|]+) \|", line)
        if m:
            rows[m.group(1)] = (m.group(2), m.group(3).strip())
    return rows


def test_every_status_is_documented_with_its_text():
    code = statuses_in_code()
    assert len(code) >= 25 and code[0] == ("Ok", "ok"), code
    table = status_table()
    for enumerator, text in code:
        assert text, f"Status::{enumerator} has no text in core/src/base/status.cpp"
        assert text in table, f"status {text} (Status::{enumerator}) is not in docs/reference/statuses.md"
        assert table[text][0] == enumerator, (text, table[text])
    assert set(table) == {text for _, text in code}, "docs/reference/statuses.md lists statuses the code does not have"


# A cheap way to each status the command line ends a run with.
EXIT_CASES = [
    ("ok", ["run", "sleigh", "--t-end", "0.1"]),
    ("inaccurate", ["run", "sleigh", "--dt", "2"]),
    ("legendre-not-solved", ["run", "suslov", "--dt", "1.5", "--t-end", "3"]),
    ("unstable-step-size", ["run", "sleigh_chain", "--set", "bodies=3", "--set", "k=1e6", "--set", "hitched=0"]),
    ("non-finite-state", ["run", "sleigh", "--set", "v0=1e200"]),
    ("precision-loss", ["run", "sleigh", "--set", "x0=1e15", "--t-end", "1"]),
    ("blew-up", ["run", "sleigh", "--method", "dla-left", "--dt", "1"]),
    ("stopped", ["run", "sleigh", "--stop-when", "x>0.5"]),
]


@pytest.mark.parametrize("status,args", EXIT_CASES, ids=[c[0] for c in EXIT_CASES])
def test_the_exit_codes_the_status_table_gives_are_the_command_lines(status, args):
    done = cli(*args)
    assert summary_of(done.stdout.strip())["status"] == status, done.stdout + done.stderr
    assert str(done.returncode) == status_table()[status][1], (status, done.returncode)


def test_a_batch_row_that_could_not_be_set_up_is_invalid_input(tmp_path):
    out = tmp_path / "batch.csv"
    done = cli("batch", "sleigh", "--count", "2", "--vary", "m=-0.5:0.2", "--t-end", "0.1", "--threads", "1",
               "--out", str(out))
    assert done.returncode == 2, done.stderr
    header, rows = read_csv(out)
    assert "invalid-input" in [row[header.index("status")] for row in rows]
    assert status_table()["invalid-input"][1] == "batch row"


def help_blocks():
    """{command: text} of the --help blocks of docs/reference/cli.md."""
    text = CLI_MD.read_text()
    return dict(re.findall(r"<!-- command: (nonholo[a-z ]*--help) -->\n```text\n(.*?)```\n<!-- end command -->", text, re.S))


def test_every_subcommand_has_its_help_block():
    # That each block is what the program prints now is Docs.ShownOutputsAreCurrent's check
    # (tools/readme_numbers.py); a missing block only this test sees.
    blocks = help_blocks()
    done = cli("--help")
    subcommands = re.findall(r"^  ([a-z]+)  ", done.stdout.split("Subcommands:")[1], re.M)
    assert len(subcommands) >= 6, done.stdout
    for command in ["nonholo --help"] + [f"nonholo {s} --help" for s in subcommands]:
        assert command in blocks, f"docs/reference/cli.md has no block for `{command}`"
        assert cli(*command.split()[1:]).returncode == 0, command


def scenes_of_list():
    """{scene: (dt, t_end, {parameter: default})} from `nonholo list`."""
    done = cli("list")
    assert done.returncode == 0, done.stderr
    scenes, current = {}, None
    for line in done.stdout.splitlines():
        m = re.match(r"^([a-z_]+): .*\(dt ([^,]+), t_end ([^)]+)\)$", line)
        if m:
            current = m.group(1)
            scenes[current] = (float(m.group(2)), float(m.group(3)), {})
            continue
        m = re.match(r"^  ([A-Za-z_0-9]+) = (\S+)  ", line)
        assert m and current, f"`nonholo list` line not understood: {line!r}"
        scenes[current][2][m.group(1)] = float(m.group(2))
    return scenes


def scenes_of_design():
    """The same from the scene sections of docs/design.md (#### `scene`, a defaults line, a table)."""
    scenes = {}
    for part in re.split(r"^#### ", DESIGN_MD.read_text(), flags=re.M)[1:]:
        m = re.match(r"`([a-z_]+)`\n", part)
        if not m:
            continue
        text = re.split(r"^#{1,3} ", part, flags=re.M)[0]  # up to the next heading
        d = re.search(r"Default `dt` ([0-9.e+-]+)[^,]*, `t_end` ([0-9.e+-]+)", text)
        assert d, f"docs/design.md, scene {m.group(1)}: no 'Default `dt` ..., `t_end` ...' line"
        parameters = {p: float(v) for p, v in re.findall(r"^\| `([A-Za-z_0-9]+)` \| ([-0-9.e+]+) ", text, re.M)}
        scenes[m.group(1)] = (float(d.group(1)), float(d.group(2)), parameters)
    return scenes


def test_the_design_documents_every_scene_with_the_codes_defaults():
    listed, documented = scenes_of_list(), scenes_of_design()
    assert sorted(documented) == sorted(listed), "docs/design.md's scene sections differ from `nonholo list`"
    close = lambda a, b: math.isclose(a, b, rel_tol=1e-5, abs_tol=0.0)  # `nonholo list` prints 6 digits
    for scene, (dt, t_end, parameters) in listed.items():
        ddt, dt_end, dparameters = documented[scene]
        assert close(ddt, dt) and close(dt_end, t_end), (scene, (ddt, dt_end), (dt, t_end))
        assert sorted(dparameters) == sorted(parameters), (scene, sorted(dparameters), sorted(parameters))
        wrong = {p: (dparameters[p], v) for p, v in parameters.items() if not close(dparameters[p], v)}
        assert not wrong, f"docs/design.md, scene {scene}: defaults (documented, code): {wrong}"


def test_the_design_keeps_its_section_numbers():
    """Comments in the code cite `docs/design.md §N`: the numbering must not move."""
    text = DESIGN_MD.read_text()
    top = re.findall(r"^## (\d+)\. ", text, re.M)
    sub = re.findall(r"^### (\d+\.\d+) ", text, re.M)
    assert top == [str(i) for i in range(1, 11)], top
    assert sub == [f"10.{i}" for i in range(1, 8)], sub
