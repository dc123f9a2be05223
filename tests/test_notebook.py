"""examples/identify.ipynb runs top to bottom in a Jupyter kernel (nbclient), as committed."""

import os
import re
from pathlib import Path

import pytest

REASON = ("the notebook test needs nbclient, nbformat and ipykernel (the `dev` extra: "
          "pip install -e '.[dev]')")
nbformat = pytest.importorskip("nbformat", reason=REASON)
nbclient = pytest.importorskip("nbclient", reason=REASON)
pytest.importorskip("ipykernel", reason=REASON)

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "examples" / "identify.ipynb"


def _outputs(nb) -> list:
    return [o for cell in nb.cells if cell.cell_type == "code" for o in cell.outputs]


def test_the_notebook_is_committed_without_outputs():
    nb = nbformat.read(NOTEBOOK, as_version=4)
    code = [cell for cell in nb.cells if cell.cell_type == "code"]
    assert code, "no code cell"
    assert not _outputs(nb), "commit the notebook without outputs (clear them first)"
    assert all(cell.execution_count is None for cell in code)


def test_the_notebook_runs_and_shows_the_results(monkeypatch):
    from jupyter_client.kernelspec import NoSuchKernel

    # the kernel (this interpreter: jupyter_client starts the python3 kernel with it) imports
    # this checkout's package
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        p for p in (str(ROOT / "src"), os.environ.get("PYTHONPATH", "")) if p))
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=240,
                                     resources={"metadata": {"path": str(NOTEBOOK.parent)}})
    try:
        client.execute()
    except NoSuchKernel:
        pytest.skip("no python3 kernelspec (python -m ipykernel install --sys-prefix)")
    except nbclient.exceptions.CellExecutionError as err:
        pytest.fail(f"a cell of {NOTEBOOK.name} failed:\n{str(err)[-3000:]}")
    outputs = _outputs(nb)
    assert not [o for o in outputs if o.output_type == "error"]
    # each identification's last expression: its Markdown view (Identification._repr_markdown_)
    markdown = [o.data["text/markdown"] for o in outputs
                if o.output_type == "execute_result" and "text/markdown" in o.get("data", {})]
    assert len(markdown) == 2, [o.output_type for o in outputs]
    for text in markdown:
        assert "kn" in text and "Verdict: ok" in text, text
    # result.plot("backbone") shows as an image
    assert any("image/png" in o.get("data", {}) for o in outputs)
    # the data set from arrays gives the files' answer
    printed = "".join(o.get("text", "") for o in outputs if o.output_type == "stream"
                      and o.name == "stdout")
    found = re.search(r"kn (\S+) N·m/rad, delta (\S+) mrad \(from the files: (\S+), (\S+)\)",
                      printed)
    assert found, printed
    assert found.group(1, 2) == found.group(3, 4)
