"""Write a benchmark's table into its own marked section of docs/REPORT.md."""

import platform
import re
import subprocess
import time
from pathlib import Path

REPORT = Path(__file__).resolve().parent.parent / "docs" / "REPORT.md"


def machine() -> str:
    try:
        cpu = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        model = re.search(r"Model name:\s*(.+)", cpu)
        model = model.group(1).strip() if model else platform.processor()
    except OSError:
        model = platform.processor()
    import os

    return f"{model}, {os.cpu_count()} cores, {time.strftime('%Y-%m-%d')}"


def write_section(name: str, title: str, body: str) -> None:
    begin, end = f"<!-- bench:{name} -->", f"<!-- /bench:{name} -->"
    block = f"{begin}\n## {title}\n\n{body.strip()}\n{end}"
    text = REPORT.read_text() if REPORT.exists() else "# DeformRT report\n"
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), re.S)
    text = pattern.sub(lambda _m: block, text) if pattern.search(text) else text.rstrip() + "\n\n" + block + "\n"
    REPORT.parent.mkdir(exist_ok=True)
    REPORT.write_text(text)


def table(header, rows) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---:" if i else "---" for i in range(len(header))) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)
