import json

import pytest

from t2m_core.atomic_files import write_json_atomic, write_text_atomic


def test_json_is_written_and_a_failed_write_keeps_the_good_file(tmp_path):
    path = tmp_path / "result.json"
    write_json_atomic(path, {"success": True})
    assert json.loads(path.read_text()) == {"success": True}
    with pytest.raises(TypeError):
        write_json_atomic(path, {"bad": object()})
    assert json.loads(path.read_text()) == {"success": True}  # the good file survived
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.json"]  # no temporary left behind


def test_text_creates_parent_directories_and_replaces(tmp_path):
    path = tmp_path / "run" / "config.yaml"
    write_text_atomic(path, "seed: 1\n")
    write_text_atomic(path, "seed: 2\n")
    assert path.read_text() == "seed: 2\n"
    assert oct(path.stat().st_mode & 0o777) == "0o644"


def test_concurrent_writability_checks_do_not_collide(tmp_path):
    """Two commands starting at once on the same --out both pass the check (a fixed probe name made
    one fail with 'No such file or directory') and leave nothing behind."""
    from concurrent.futures import ThreadPoolExecutor

    from t2m_core.atomic_files import ensure_writable_directory

    target = tmp_path / "out"
    with ThreadPoolExecutor(8) as pool:
        results = list(pool.map(lambda _: ensure_writable_directory(target), range(400)))
    assert results == [target] * 400
    assert list(target.iterdir()) == []
