"""Build dist/deformrt-<version>-<platform>.zip with Blender's own extension tool.

Fetches exactly the wheels blender_manifest.toml lists (pinned names, cached in
./wheels), then runs the `build --split-platforms` and `validate` commands of
blender_ext.py, the tool the bpy package ships inside Blender's extension add-on.

    python .ci/build.py            # every platform in the manifest
    python .ci/build.py --check    # only report which wheels are missing
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def blender_ext_tool() -> Path:
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        sys.exit("build: the bpy package is not installed in this Python (pip install 'bpy==4.5.*')")
    pkg = Path(next(iter(spec.submodule_search_locations)))
    found = sorted(pkg.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        sys.exit(f"build: no blender_ext.py inside {pkg}")
    return found[-1]


def wheel_download_args(filename: str) -> list[str]:
    name, version, py_tag, abi_tag, plat_tag = filename[: -len(".whl")].split("-")
    python = f"3.{py_tag[3:]}" if py_tag.startswith("cp3") else "3.11"  # cp313 -> 3.13; py3: any
    args = ["--no-deps", "--only-binary=:all:", "--python-version", python, f"{name}=={version}"]
    if plat_tag != "any":
        args += ["--abi", abi_tag]
        for plat in plat_tag.split("."):
            args += ["--platform", plat]
        if py_tag.startswith("cp"):
            args += ["--implementation", "cp"]
    return args


def fetch_wheels(manifest: dict, check_only: bool) -> list[str]:
    missing = [w for w in manifest.get("wheels", []) if not (ROOT / w).is_file()]
    if check_only:
        return missing
    (ROOT / "wheels").mkdir(exist_ok=True)
    for rel in missing:
        target = ROOT / rel
        print(f"build: fetching {target.name}", flush=True)
        pip = [sys.executable, "-m", "pip", "download", "-q", "-d", str(target.parent)]
        subprocess.run([*pip, *wheel_download_args(target.name)], check=True)
        if not target.is_file():
            sys.exit(f"build: pip did not produce {target.name}; update blender_manifest.toml to the name it served")
    return []


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--output-dir", default=str(ROOT / "dist"))
    ap.add_argument("--check", action="store_true", help="list missing wheels and exit")
    args = ap.parse_args(argv)

    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    missing = fetch_wheels(manifest, args.check)
    if args.check:
        print("\n".join(missing) or "all wheels present")
        return 1 if missing else 0

    out = Path(args.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    for old in out.glob(f"{manifest['id']}-{manifest['version']}-*.zip"):
        old.unlink()
    tool = blender_ext_tool()
    subprocess.run(
        [sys.executable, str(tool), "build", "--source-dir", str(ROOT), "--output-dir", str(out), "--split-platforms"],
        check=True,
    )
    zips = sorted(out.glob(f"{manifest['id']}-{manifest['version']}-*.zip"))
    if len(zips) != len(manifest["platforms"]):
        sys.exit(f"build: expected {len(manifest['platforms'])} zips, found {[z.name for z in zips]}")
    for z in zips:
        subprocess.run([sys.executable, str(tool), "validate", str(z)], check=True)
        print(f"build: {z.name} {z.stat().st_size / 1e6:.1f} MB, valid")
    return 0


if __name__ == "__main__":
    sys.exit(main())
