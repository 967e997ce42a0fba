"""Test session setup: a private clip cache, so tests never read a stale user cache and a
fresh CI run renders (and so tests) the real rendering path."""

import os

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(scope="session", autouse=True)
def private_clip_cache(tmp_path_factory: pytest.TempPathFactory) -> None:
    os.environ["IMIMIC_CACHE_DIR"] = str(tmp_path_factory.mktemp("clip_cache"))
