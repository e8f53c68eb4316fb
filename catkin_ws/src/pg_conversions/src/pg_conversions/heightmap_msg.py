"""Conversions between pg_core's heightmaps and ROS messages (message classes only, no rospy).

- pg_msgs/Heightmap <-> pg_core.heightmap.Heightmap (rgb8 colour, 32FC1 height in metres above z_min, mono8 valid;
  frame `world`).
- numpy (H, W[, C]) arrays -> sensor_msgs/Image of a given encoding.
Malformed messages raise ValueError naming what is wrong.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pg_core.heightmap import Heightmap


def _image_array(img: Any, dtype: Any, channels: int) -> np.ndarray:
    """(H, W[, C]) array of a sensor_msgs/Image; ValueError on a size/step mismatch."""
    itemsize = np.dtype(dtype).itemsize * channels
    if img.step < img.width * itemsize or len(img.data) < img.step * img.height:
        raise ValueError(f"image {img.width}x{img.height} step {img.step} holds {len(img.data)} bytes: malformed")
    arr = np.frombuffer(bytes(img.data), dtype=np.uint8).reshape(img.height, img.step)[:, : img.width * itemsize]
    arr = arr.copy().view(dtype).reshape(img.height, img.width, channels)
    if img.is_bigendian != (np.dtype(dtype).byteorder == ">"):
        arr = arr.byteswap() if np.dtype(dtype).itemsize > 1 else arr
    return arr if channels > 1 else arr[:, :, 0]


def heightmap_from_msg(msg: Any) -> Heightmap:
    """pg_msgs/Heightmap -> Heightmap; ValueError for wrong encodings or sizes."""
    for name, enc in (("color", "rgb8"), ("height", "32FC1"), ("valid", "mono8")):
        got = getattr(msg, name).encoding
        if got != enc:
            raise ValueError(f"heightmap {name} encoding is {got!r}, expected {enc!r}")
    color = _image_array(msg.color, np.uint8, 3)
    height = _image_array(msg.height, np.float32, 1)
    valid = _image_array(msg.valid, np.uint8, 1) > 0
    if not (color.shape[:2] == height.shape == valid.shape):
        raise ValueError(f"heightmap images differ in size: {color.shape[:2]} {height.shape} {valid.shape}")
    bounds = np.array([[msg.x_min, msg.x_max], [msg.y_min, msg.y_max], [msg.z_min, msg.z_max]], dtype=np.float64)
    return Heightmap(color, height.astype(np.float32), valid, float(msg.resolution), bounds)


def image_msg(arr: np.ndarray, encoding: str, header: Any) -> Any:
    from sensor_msgs.msg import Image

    arr = np.ascontiguousarray(arr)
    channels = arr.shape[2] if arr.ndim == 3 else 1
    return Image(header=header, height=arr.shape[0], width=arr.shape[1], encoding=encoding, is_bigendian=0,
                 step=arr.shape[1] * channels * arr.dtype.itemsize, data=arr.tobytes())


def heightmap_to_msg(hm: Heightmap, header: Any) -> Any:
    """Heightmap -> pg_msgs/Heightmap (header.frame_id should be `world`)."""
    from pg_msgs.msg import Heightmap as HeightmapMsg

    b = hm.bounds
    return HeightmapMsg(header=header, resolution=hm.resolution, x_min=b[0, 0], x_max=b[0, 1], y_min=b[1, 0],
                        y_max=b[1, 1], z_min=b[2, 0], z_max=b[2, 1], color=image_msg(hm.color, "rgb8", header),
                        height=image_msg(hm.height.astype(np.float32), "32FC1", header),
                        valid=image_msg(hm.valid.astype(np.uint8) * 255, "mono8", header))
