"""Build dist/deformrt-<version>-<platform>.zip with Blender's own extension tool.

Fetches exactly the wheels blender_manifest.toml lists (pinned names, cached in
./wheels), then runs the `build --split-platforms` and `validate` commands of
blender_ext.py, the tool the bpy package ships inside Blender's extension add-on.

    python .ci/build.py                  # every platform in the manifest
    python .ci/build.py --this-platform  # only this machine's zip (its wheels only: about 100 MB)
    python .ci/build.py --check          # only report which wheels are missing
"""

from __future__ import annotations

import argparse
import importlib.util
import platform
import re
import shutil
import subprocess
import sys
import tempfile
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


# a wheel's platform tag -> the manifest's platform it serves ("any" wheels serve every one)
_WHEEL_PLATFORM = {"linux-x64": ("linux", "x86_64"), "windows-x64": ("win_amd64",),
                   "macos-arm64": ("macosx_", "arm64")}
_SKIPPED = shutil.ignore_patterns(".git", ".venv", ".venv-blender", "dist", "wheels", "out", "__pycache__",
                                  ".pytest_cache", ".ruff_cache")


def this_platform() -> str:
    """This machine as the manifest names platforms (linux-x64, windows-x64, macos-arm64)."""
    system = {"linux": "linux", "win32": "windows", "darwin": "macos"}.get(sys.platform, sys.platform)
    arch = "arm64" if platform.machine().lower() in ("arm64", "aarch64") else "x64"
    return f"{system}-{arch}"


def serves(wheel: str, plat: str) -> bool:
    tag = wheel[: -len(".whl")].rsplit("-", 1)[-1]
    return tag == "any" or all(part in tag for part in _WHEEL_PLATFORM[plat])


def one_platform_manifest(text: str, plat: str, wheels: list[str]) -> str:
    """The manifest's text with ``platforms`` and ``wheels`` cut to one platform."""
    text = re.sub(r"^platforms\s*=\s*\[[^\]]*\]", f'platforms = ["{plat}"]', text, count=1, flags=re.M)
    listed = ",\n".join(f'  "{w}"' for w in wheels)
    return re.sub(r"^wheels\s*=\s*\[[^\]]*\]", f"wheels = [\n{listed},\n]", text, count=1, flags=re.M)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--output-dir", default=str(ROOT / "dist"))
    ap.add_argument("--check", action="store_true", help="list missing wheels and exit")
    ap.add_argument("--this-platform", action="store_true", help="build only this machine's zip")
    args = ap.parse_args(argv)

    text = (ROOT / "blender_manifest.toml").read_text()
    manifest = tomllib.loads(text)
    if args.this_platform:
        plat = this_platform()
        if plat not in manifest["platforms"]:
            sys.exit(f"build: this machine ({plat}) is not one of the manifest's platforms {manifest['platforms']}")
        manifest["wheels"] = [w for w in manifest["wheels"] if serves(Path(w).name, plat)]
        manifest["platforms"] = [plat]
    missing = fetch_wheels(manifest, args.check)
    if args.check:
        print("\n".join(missing) or "all wheels present")
        return 1 if missing else 0

    out = Path(args.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    for plat in manifest["platforms"]:  # Blender names a platform's zip with an underscore: linux_x64
        (out / f"{manifest['id']}-{manifest['version']}-{plat.replace('-', '_')}.zip").unlink(missing_ok=True)
    tool = blender_ext_tool()
    with tempfile.TemporaryDirectory(prefix="deformrt-build-") as tmp:
        source = ROOT
        if args.this_platform:  # a copy of the sources whose manifest names this platform and its wheels
            source = Path(tmp) / "src"
            shutil.copytree(ROOT, source, ignore=_SKIPPED)
            (source / "wheels").mkdir()
            for w in manifest["wheels"]:
                shutil.copy2(ROOT / w, source / w)
            (source / "blender_manifest.toml").write_text(
                one_platform_manifest(text, manifest["platforms"][0], manifest["wheels"]))
        subprocess.run([sys.executable, str(tool), "build", "--source-dir", str(source), "--output-dir", str(out),
                        "--split-platforms"], check=True)
    zips = [out / f"{manifest['id']}-{manifest['version']}-{p.replace('-', '_')}.zip" for p in manifest["platforms"]]
    if not all(z.is_file() for z in zips):
        sys.exit(f"build: expected {len(manifest['platforms'])} zips, found {[z.name for z in zips]}")
    for z in zips:
        subprocess.run([sys.executable, str(tool), "validate", str(z)], check=True)
        print(f"build: {z} {z.stat().st_size / 1e6:.1f} MB, valid: install it from Preferences > Get Extensions >"
              " Install from Disk")
    return 0


if __name__ == "__main__":
    sys.exit(main())
