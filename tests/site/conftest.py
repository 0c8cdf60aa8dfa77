import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SITE = ROOT / "examples" / "site"


@pytest.fixture(scope="session")
def make_site():
    """The example-site generator module (examples/site/make_site.py)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_site", SITE / "make_site.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["make_site"] = mod
    spec.loader.exec_module(mod)
    return mod


def site_toml(tmp_path, replace: dict | None = None, drop=(), extra_site: str = "") -> Path:
    """The example site.toml with absolute paths, keys replaced / dropped, written into *tmp_path*."""
    lines = []
    for ln in (SITE / "site.toml").read_text().splitlines():
        key = ln.split("=")[0].strip()
        if key in drop:
            continue
        if key in (replace or {}):
            ln = f"{key} = {replace[key]}"
        elif key in ("terrain", "levee"):
            ln = f'{key} = "{SITE / ln.split(chr(34))[1]}"'
        lines.append(ln)
        if ln.strip() == "[site]" and extra_site:
            lines.append(extra_site)
    p = tmp_path / "site.toml"
    p.write_text("\n".join(lines) + "\n")
    return p
