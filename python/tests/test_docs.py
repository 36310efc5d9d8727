"""The examples of docs/python.md run as written (every ```python block, in order, in one
namespace), so the page cannot drift from the package."""

import re

from conftest import REPO


def test_the_python_guide_examples_run(tmp_path, monkeypatch, capsys):
    text = (REPO / "docs" / "python.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 6
    monkeypatch.chdir(tmp_path)
    namespace = {}
    try:
        import mitsuba  # noqa: F401

        have_mitsuba = True
    except ImportError:
        have_mitsuba = False
    for i, code in enumerate(blocks):
        if code.startswith("# requires mitsuba") and not have_mitsuba:
            continue
        exec(compile(code, f"docs/python.md block {i + 1}", "exec"), namespace)
    out = capsys.readouterr().out
    assert "points: must be a float64 numpy array of shape (n, 3)" in out
    assert "lobe8-tilt30 Phong lobe e = 8, tilt 30°" in out


def test_the_own_integrand_guide_examples_run(tmp_path, monkeypatch, capsys):
    text = (REPO / "docs" / "guide" / "python-integrands.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 4
    monkeypatch.chdir(tmp_path)
    namespace = {}
    for i, code in enumerate(blocks):
        exec(compile(code, f"docs/guide/python-integrands.md block {i + 1}", "exec"), namespace)
    out = capsys.readouterr().out
    assert out.startswith("True\n"), out
    assert "GGX D(ω) cos θ, α = 0.3 (ggx-cos): ∫ f dω = 1.0000000000" in out
    assert 'integrand "broken", trial 0, N = 8: value inf at direction' in out
    assert (tmp_path / "ggx" / "ggx-cos.svg").exists()
