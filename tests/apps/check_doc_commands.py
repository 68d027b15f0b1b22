#!/usr/bin/python3
"""Every `shearzone ...` command shown in README.md and docs/*.md exists and is run by a
test or by a script, so the documentation cannot rot.

    check_doc_commands.py REPO_ROOT SHEARZONE_BINARY [-v]

1. Commands are the lines of code blocks (fenced, or indented by 4 spaces) whose first
   word is `shearzone` (or a path ending in /shearzone), after an optional `$ ` prompt;
   backslash-continued lines are joined, `# comments` dropped, and a line is cut at
   `&&`, `||`, `;` and `|`. Output lines such as `shearzone: error: ...` do not count
   (their first word is `shearzone:`).
2. The subcommand path must exist (`shearzone --help`, `shearzone fit --help` ...) and
   every option used (`--long`, `-x`) must appear in that subcommand's --help (or in the
   top-level --help: -q, -v).
3. The command must be run somewhere: its words after `shearzone`, as the shell splits
   them (quotes removed), must equal
   - the ARGS or SETUP_ARGS of a shearzone_cli_test(...) in tests/apps/CMakeLists.txt,
     with its set() variables expanded; `${PROJECT_SOURCE_DIR}/` is dropped (the docs
     name repository files relative to the repository root, the tests run in a scratch
     folder) and so is `${SZ_CLI_WORK}/<test>/` (another test's scratch folder); or
   - a `"$SZ" ...` line of a shell script under scripts/ (scripts/demo.sh,
     scripts/test_figures.sh ...) or of a test's shell script under tests/ (the study
     workflow's, tests/study/), with the script's variables replaced by the values
     assigned to them earlier in the script; a variable whose value is only known at
     run time ($(...), $1) stands for the folder the commands run in, so
     `"$OUT/fits/erf.csv"` is `fits/erf.csv` (and a bare `"$OUT"` is `.`).
   There are no other placeholders: write examples that a test or a script runs.

Prints one line per failing command (file:line, command, reason) and exits 1 if any
fails; otherwise prints a count summary. Python 3 standard library only.
"""
import glob
import os
import re
import shlex
import subprocess
import sys

SEPARATORS = {"&&", "||", ";", "|"}
VAR = re.compile(r"\$\{(\w+)\}|\$(\w+)")
CALL = re.compile(r"([A-Za-z_]\w*)\s*\(")


# ---- documentation ---------------------------------------------------------------

def code_lines(text):
    """(line number, text) of every line inside a code block of a Markdown text, with
    backslash continuations joined (numbered by their first line)."""
    raw = []
    fence = None
    in_indented = False
    prev_blank = True
    for no, line in enumerate(text.splitlines(), 1):
        if fence is not None:
            s = line.strip()
            if s.startswith(fence) and set(s) == {fence[0]}:
                fence = None
                prev_blank = False
            else:
                raw.append((no, line, True))
            continue
        m = re.match(r"^ {0,3}(`{3,}|~{3,})", line)
        if m:
            fence = m.group(1)
            in_indented = False
            continue
        if not line.strip():
            prev_blank = True
            if in_indented:
                raw.append((no, "", False))
            continue
        if line.startswith("    ") and (in_indented or prev_blank):
            in_indented = True
            raw.append((no, line[4:], False))
        else:
            in_indented = False
        prev_blank = False
    return join_continuations((no, line) for no, line, _ in raw)


def join_continuations(numbered):
    """Joins backslash-continued lines: [(first line number, joined text)]."""
    out, pending, start = [], "", None
    for no, line in numbered:
        if start is None:
            start = no
        if line.rstrip().endswith("\\"):
            pending += line.rstrip()[:-1] + " "
            continue
        out.append((start, pending + line))
        pending, start = "", None
    if pending:
        out.append((start, pending))
    return out


def split_words(text):
    """Shell words of a line (quotes removed, comments dropped); None if unbalanced."""
    try:
        return shlex.split(text, comments=True)
    except ValueError:
        return None


def segments(words):
    """The words split at &&, ||, ; and |."""
    cur = []
    for w in words:
        if w in SEPARATORS:
            if cur:
                yield cur
            cur = []
        else:
            cur.append(w)
    if cur:
        yield cur


def is_shearzone(word):
    return word == "shearzone" or word.endswith("/shearzone")


def doc_commands(root):
    """(file, line, words after `shearzone`) of every documented command."""
    files = [os.path.join(root, "README.md")] + sorted(glob.glob(os.path.join(root, "docs", "*.md")))
    found = []
    for path in files:
        if not os.path.exists(path):
            continue
        with open(path, encoding="utf-8") as f:
            text = f.read()
        for no, line in code_lines(text):
            s = line.strip()
            if s.startswith("$ "):
                s = s[2:]
            words = split_words(s)
            if not words:
                continue
            for seg in segments(words):
                if is_shearzone(seg[0]):
                    found.append((os.path.relpath(path, root), no, seg[1:]))
    return found


# ---- what the tests and scripts run ----------------------------------------------

def cmake_commands(text):
    """(name, [(quoted, text), ...]) of every command invocation in a CMake file."""
    i, n = 0, len(text)
    out = []
    while i < n:
        c = text[i]
        if c == "#":
            j = text.find("\n", i)
            i = n if j < 0 else j + 1
            continue
        m = CALL.match(text, i)
        if not m or (i > 0 and (text[i - 1].isalnum() or text[i - 1] == "_")):
            i += 1
            continue
        name = m.group(1)
        i = m.end()
        args, depth = [], 0
        while i < n:
            c = text[i]
            if c.isspace():
                i += 1
            elif c == "#":
                j = text.find("\n", i)
                i = n if j < 0 else j + 1
            elif c == '"':
                j, buf = i + 1, []
                while j < n and text[j] != '"':
                    if text[j] == "\\" and j + 1 < n:
                        e = text[j + 1]
                        buf.append({"n": "\n", "t": "\t", '"': '"', "\\": "\\"}.get(e, "\\" + e))
                        j += 2
                    else:
                        buf.append(text[j])
                        j += 1
                args.append((True, "".join(buf)))
                i = j + 1
            elif c == "(":
                depth += 1
                args.append((False, "("))
                i += 1
            elif c == ")":
                if depth == 0:
                    i += 1
                    break
                depth -= 1
                args.append((False, ")"))
                i += 1
            else:
                j = i
                while j < n and not text[j].isspace() and text[j] not in '()"#':
                    j += 1
                args.append((False, text[i:j]))
                i = j
        out.append((name, args))
    return out


def cmake_expand(args, variables):
    """CMake argument expansion: ${VAR} replaced; unquoted arguments split at ';'."""
    def sub(s):
        return VAR.sub(lambda m: variables.get(m.group(1), m.group(0)) if m.group(1) else m.group(0), s)
    out = []
    for quoted, t in args:
        v = sub(t)
        if quoted:
            out.append(v)
        else:
            out.extend(x for x in v.split(";") if x != "")
    return out


CLI_ONE = {"CODE", "STDERR", "STDOUT", "SETUP_FILE", "SETUP_TEXT", "FILE", "FILE_MATCHES", "SAME_STDOUT"}
CLI_MULTI = {"ARGS", "ABSENT", "PRESENT", "SETUP_ARGS"}


def normalise_cmake_word(w):
    w = w.replace("${PROJECT_SOURCE_DIR}/", "")
    w = w.replace("${CMAKE_CURRENT_SOURCE_DIR}/", "tests/apps/")
    return re.sub(r"\$\{SZ_CLI_WORK\}/[^/]+/", "", w)


def cli_test_runs(path):
    """{words: description} of the ARGS and SETUP_ARGS of every shearzone_cli_test."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    variables, runs = {}, {}
    for name, args in cmake_commands(text):
        if name == "set" and args:
            values = cmake_expand(args[1:], variables)
            variables[args[0][1]] = ";".join(values)
        elif name == "shearzone_cli_test":
            words = cmake_expand(args, variables)
            test, parsed, key = words[0], {}, None
            for w in words[1:]:
                if w in CLI_ONE or w in CLI_MULTI:
                    key = w
                    parsed.setdefault(key, [])
                elif key is not None:
                    parsed[key].append(w)
                    if key in CLI_ONE:
                        key = None
            for kind in ("ARGS", "SETUP_ARGS"):
                if kind in parsed:
                    seq = tuple(normalise_cmake_word(w) for w in parsed[kind])
                    code = parsed.get("CODE", ["?"])[0] if kind == "ARGS" else "0"
                    runs.setdefault(seq, f"CLI test '{test}' {kind} (exit {code})")
    return runs


RUNTIME = re.compile(r"\$\(|`|\$[0-9@*#?]|\$\{\w+:")


def script_runs(path, root):
    """{words: description} of the `"$SZ" ...` lines of a shell script."""
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    joined = join_continuations(enumerate(lines, 1))
    values = {}  # name -> value, or None when only known at run time

    def expand(s):
        def one(m):
            name = m.group(1) or m.group(2)
            if name not in values:
                return m.group(0)
            return "\0RUNTIME\0" if values[name] is None else values[name]
        s = VAR.sub(one, s)
        return s.replace("\0RUNTIME\0/", "").replace("\0RUNTIME\0", ".")

    runs = {}
    rel = os.path.relpath(path, root)
    for no, line in joined:
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        m = re.match(r"^([A-Za-z_]\w*)=(.*)$", s)
        if m:
            raw = m.group(2)
            if RUNTIME.search(raw):
                values[m.group(1)] = None
            else:
                w = split_words(expand(raw))
                values[m.group(1)] = w[0] if w and len(w) == 1 else ("" if w == [] else None)
            continue
        first = s.split(None, 1)[0]
        if first.strip('"') in ("$SZ", "${SZ}") or is_shearzone(first):
            rest = s[len(first):]
            words = split_words(expand(rest))
            if words is None:
                continue
            seg = next(segments(words), [])
            seg = [w for w in seg if not re.match(r"^[0-9]*[<>]", w)]
            runs.setdefault(tuple(seg), f"{rel}:{no}")
    return runs


# ---- the binary's --help ---------------------------------------------------------

class Help:
    def __init__(self, binary):
        self.binary = binary
        self.cache = {}

    def get(self, path):
        """(subcommands, options) of `shearzone PATH --help`, or None if it fails."""
        key = tuple(path)
        if key not in self.cache:
            r = subprocess.run([self.binary, *path, "--help"], capture_output=True, text=True)
            if r.returncode != 0:
                self.cache[key] = None
            else:
                subs, opts, section = set(), set(), None
                for line in r.stdout.splitlines():
                    if re.match(r"^\S.*:$", line):
                        section = line[:-1]
                        if section == "Positionals":  # a command with subcommands may take its own arguments
                            subs.add(POSITIONALS)
                        continue
                    m = re.match(r"^  (\S+)", line)
                    if not m:
                        continue
                    if section == "Subcommands":
                        subs.add(m.group(1))
                    elif section == "Options" and m.group(1).startswith("-"):
                        opts.update(x for x in m.group(1).split(",") if x.startswith("-"))
                self.cache[key] = (subs, opts)
        return self.cache[key]


POSITIONALS = "<positionals>"  # in a command's subcommand set: it also runs with its own positionals


def is_option(w):
    return w.startswith("--") and len(w) > 2 or re.match(r"^-[A-Za-z]$", w) is not None


def check_exists(words, helps):
    """None if the subcommand path and every option exist, else the reason."""
    top = helps.get([])
    if top is None:
        return "`shearzone --help` failed"
    path, i = [], 0
    subs, opts = top
    global_opts = top[1]
    while i < len(words) and is_option(words[i]):
        if words[i].split("=", 1)[0] not in global_opts:
            return f"option {words[i]} is not in `shearzone --help`"
        i += 1
    while i < len(words) and subs:
        w = words[i]
        if is_option(w):
            break
        if w not in subs and POSITIONALS in subs:
            break  # `shearzone sim SCENE ...`: the command itself, not a subcommand
        if w not in subs:
            where = " ".join(["shearzone", *path])
            return f"`{where}` has no subcommand {w!r} (expected one of: {', '.join(sorted(subs - {POSITIONALS}))})"
        path.append(w)
        h = helps.get(path)
        if h is None:
            return f"`shearzone {' '.join(path)} --help` failed"
        subs, opts = h
        i += 1
    for w in words[i:]:
        if w == "--":
            break
        if is_option(w):
            name = w.split("=", 1)[0]
            if name not in opts and name not in global_opts:
                return f"option {name} is not in `shearzone {' '.join(path)} --help`"
    return None


def main(argv):
    args = [a for a in argv[1:] if a not in ("-v", "--verbose")]
    verbose = len(args) != len(argv) - 1
    if len(args) != 2:
        print("usage: check_doc_commands.py REPO_ROOT SHEARZONE_BINARY [-v]", file=sys.stderr)
        return 2
    root, binary = os.path.abspath(args[0]), args[1]
    runs = cli_test_runs(os.path.join(root, "tests", "apps", "CMakeLists.txt"))
    n_tests = len(runs)
    scripts = sorted(glob.glob(os.path.join(root, "scripts", "*.sh")))
    scripts += sorted(glob.glob(os.path.join(root, "tests", "**", "*.sh"), recursive=True))
    for script in scripts:
        for k, v in script_runs(script, root).items():
            runs.setdefault(k, v)
    helps = Help(binary)
    commands = doc_commands(root)
    failures, by_test, by_script = [], 0, 0
    for path, no, words in commands:
        shown = " ".join(["shearzone", *(shlex.quote(w) for w in words)])
        reason = check_exists(words, helps)
        where = runs.get(tuple(words))
        if reason is None and where is None:
            reason = ("not run by any shearzone_cli_test (ARGS or SETUP_ARGS) in "
                      "tests/apps/CMakeLists.txt nor by a script under scripts/ or tests/")
        if reason is not None:
            failures.append(f"{path}:{no}: {shown}: {reason}")
            continue
        if where.startswith("CLI test"):
            by_test += 1
        else:
            by_script += 1
        if verbose:
            print(f"ok {path}:{no}: {shown}  <- {where}")
    for f in failures:
        print(f)
    files = len({p for p, _, _ in commands})
    if not commands:
        print("check_doc_commands: no `shearzone` command found in README.md and docs/*.md")
        return 1
    if failures:
        print(f"check_doc_commands: {len(failures)} of {len(commands)} commands in {files} files fail")
        return 1
    print(f"check_doc_commands: {len(commands)} commands in {files} files: every subcommand and "
          f"option exists; {by_test} run by CLI tests, {by_script} by scripts "
          f"({n_tests} CLI test command lines, {len(runs) - n_tests} script lines known)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
