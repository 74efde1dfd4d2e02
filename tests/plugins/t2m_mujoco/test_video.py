import numpy as np
import pytest

from t2m_core.video import VideoWriter, write_mp4


def test_write_mp4_atomically(tmp_path):
    frames = [np.full((32, 48, 3), i * 20, dtype=np.uint8) for i in range(10)]
    path = write_mp4(tmp_path / "video.mp4", frames, fps=10)
    assert path.stat().st_size > 100
    assert [p.name for p in tmp_path.iterdir()] == ["video.mp4"]


def test_failed_video_leaves_old_file(tmp_path):
    target = tmp_path / "video.mp4"
    target.write_bytes(b"good")
    with pytest.raises(ValueError, match="differs"):
        with VideoWriter(target) as video:
            video.add(np.zeros((32, 48, 3), np.uint8))
            video.add(np.zeros((16, 16, 3), np.uint8))
    assert target.read_bytes() == b"good"
    assert [p.name for p in tmp_path.iterdir()] == ["video.mp4"]


def test_rejects_bad_frames(tmp_path):
    with pytest.raises(ValueError, match="uint8"):
        with VideoWriter(tmp_path / "v.mp4") as video:
            video.add(np.zeros((8, 8), np.float32))


def test_removes_a_killed_writers_temporary(tmp_path):
    stale = tmp_path / ".video-abc123.mp4"  # what a SIGKILLed writer leaves
    stale.write_bytes(b"partial")
    other = tmp_path / ".other-abc123.mp4"  # another destination's: not ours to remove
    other.write_bytes(b"partial")
    write_mp4(tmp_path / "video.mp4", [np.zeros((16, 16, 3), np.uint8)] * 3, fps=10)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".other-abc123.mp4", "video.mp4"]
