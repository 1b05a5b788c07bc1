"""Shared test set-up: nothing a test does may write into the user's home."""

import pytest


@pytest.fixture(autouse=True)
def private_recovery_dir(tmp_path, monkeypatch):
    """The app's autosave folder, private to each test."""
    monkeypatch.setenv("WRINKLE_VIS_RECOVERY_DIR", str(tmp_path / "recovery-default"))
