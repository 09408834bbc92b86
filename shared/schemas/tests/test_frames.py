import numpy as np
import pytest
from llmland_schemas import CameraFrameHeader, CameraIntrinsics, MessageError, decode_frame, encode_frame


def _header(w=8, h=6, depth=True):
    return CameraFrameHeader(
        stamp=1.0, seq=3, width=w, height=h,
        intrinsics=CameraIntrinsics(fx=4, fy=4, cx=w / 2, cy=h / 2, width=w, height=h),
        T_world_camera=list(np.eye(4).reshape(-1)),
        depth_encoding="32FC1" if depth else None,
    )


def test_frame_round_trip():
    rng = np.random.default_rng(0)
    rgb = rng.integers(0, 255, (6, 8, 3), dtype=np.uint8)
    depth = rng.random((6, 8)).astype(np.float32)
    depth[0, 0] = np.inf
    frame = decode_frame(encode_frame(_header(), rgb, depth))
    assert frame.header.seq == 3
    np.testing.assert_array_equal(frame.rgb, rgb)
    np.testing.assert_array_equal(frame.depth_m, depth)
    np.testing.assert_array_equal(frame.T_world_camera, np.eye(4))


def test_frame_without_depth():
    rgb = np.zeros((6, 8, 3), np.uint8)
    frame = decode_frame(encode_frame(_header(depth=False), rgb, None))
    assert frame.depth_m is None


@pytest.mark.parametrize("cut", [0, 3, 10, 40, -1, -200])
def test_truncated_frames_are_rejected(cut):
    payload = encode_frame(_header(), np.zeros((6, 8, 3), np.uint8), np.ones((6, 8), np.float32))
    with pytest.raises(MessageError):
        decode_frame(payload[:cut])


def test_wrong_magic_and_sizes_rejected():
    payload = encode_frame(_header(), np.zeros((6, 8, 3), np.uint8), np.ones((6, 8), np.float32))
    with pytest.raises(MessageError):
        decode_frame(b"XXXX" + payload[4:])
    with pytest.raises(MessageError):
        decode_frame(payload + b"\0")
    with pytest.raises(ValueError):
        encode_frame(_header(), np.zeros((5, 8, 3), np.uint8), np.ones((6, 8), np.float32))


def test_nan_depth_rejected():
    depth = np.ones((6, 8), np.float32)
    depth[2, 2] = np.nan
    with pytest.raises(MessageError):
        decode_frame(encode_frame(_header(), np.zeros((6, 8, 3), np.uint8), depth))
