"""Intel's CPU runtime registered by a vendor folder lutbake writes for OCL_ICD_VENDORS."""

import pytest

from lutbake.integrate import icd


def test_the_vendor_folder_links_the_systems_runtimes_and_names_intels(tmp_path):
    """A link to each .icd of the system's folder and one .icd naming Intel's library; written again, it is
    brought up to date (an .icd the system no longer holds goes, what it holds now comes)."""
    system, library = tmp_path / "system", tmp_path / "libintelocl.so"
    system.mkdir()
    library.write_bytes(b"")
    for name in ("pocl.icd", "gpu.icd"):
        (system / name).write_text(f"lib{name[:-4]}.so\n")
    (system / "notes.txt").write_text("not an icd")
    folder = icd.write_vendor_folder(tmp_path / "vendors", library, system)
    assert sorted(p.name for p in folder.iterdir()) == ["gpu.icd", icd.INTEL_ICD, "pocl.icd"]
    assert (folder / "pocl.icd").resolve() == (system / "pocl.icd").resolve()
    assert (folder / icd.INTEL_ICD).read_text() == f"{library.resolve()}\n"
    (system / "gpu.icd").unlink()
    (system / "new.icd").write_text("libnew.so\n")
    icd.write_vendor_folder(folder, library, system)
    assert sorted(p.name for p in folder.iterdir()) == [icd.INTEL_ICD, "new.icd", "pocl.icd"]
    with pytest.raises(ValueError, match="is the system's own"):
        icd.write_vendor_folder(system, library, system)


def test_intel_vendor_folder_refuses_an_environment_without_intels_runtime(tmp_path, monkeypatch):
    monkeypatch.setattr(icd, "environment_intel_library", lambda: None)
    with pytest.raises(ValueError, match="not installed"):
        icd.intel_vendor_folder(tmp_path)
    assert not any(tmp_path.iterdir())
