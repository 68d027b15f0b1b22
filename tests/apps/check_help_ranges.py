#!/usr/bin/python3
"""Every numeric option (INT, UINT or FLOAT in --help) of every subcommand states its
range: its description ends with "; range: ..." (README, "Limits on inputs").

    check_help_ranges.py BIN
"""
import re
import subprocess
import sys

COMMANDS = [["synth", "particles"], ["synth", "beads"], ["piv"], ["profile"], ["width"],
            ["fit", "erf"], ["fit", "power"], ["laos"], ["sim"], ["sim", "render"], ["sim", "check"], ["collapse", "erf"],
            ["collapse", "fss"], ["bench", "piv"], ["bench", "sim"]]
OPTION = re.compile(r"^  (-[-\w,]+)(?: (\S+(?: x \d+)?(?: \.\.\.)?))?(?:\s{2,}(.*))?$")


def options(text):
    """(names, type, description) of each option in a CLI11 help text."""
    out, cur = [], None
    for line in text.splitlines():
        m = OPTION.match(line)
        if m:
            cur = [m.group(1), m.group(2) or "", m.group(3) or ""]
            out.append(cur)
        elif cur is not None and line.startswith("      ") and line.strip():
            cur[2] += " " + line.strip()
        else:
            cur = None
    return out


def main():
    bin_ = sys.argv[1]
    missing, numeric = [], 0
    for cmd in COMMANDS:
        text = subprocess.run([bin_, *cmd, "--help"], capture_output=True, text=True, check=True).stdout
        for names, type_, desc in options(text):
            if not re.match(r"(INT|UINT|FLOAT)\b", type_):
                continue
            numeric += 1
            if "; range: " not in desc:
                missing.append(f"shearzone {' '.join(cmd)} {names}: {desc!r}")
    for m in missing:
        print("no range:", m)
    print(f"{numeric - len(missing)} of {numeric} numeric options state their range")
    return 1 if missing or numeric < 100 else 0


if __name__ == "__main__":
    sys.exit(main())
