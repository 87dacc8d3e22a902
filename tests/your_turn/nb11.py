"""Fill-ins for notebooks/11_map_frame_and_many_logs.ipynb: composing two SE(2) poses, a pose at a stamp."""

from tests.your_turn import Fill

_COMPOSE = "def compose_poses(a, b):\n"
_POSE_AT = "def pose_at(t0, p0, t1, p1, t):\n"

FILLS = {
    "a7ab2543": Fill(
        correct=_COMPOSE + (
            "    wrap = labkit.geometry.wrap_angle\n"
            "    c, s = np.cos(a[2]), np.sin(a[2])\n"
            "    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap(a[2] + b[2])])\n"),
        # translations added as if both frames were aligned
        mistake=_COMPOSE + "    return np.array([a[0] + b[0], a[1] + b[1], labkit.geometry.wrap_angle(a[2] + b[2])])\n",
        hint="rotate b's translation by a's heading",
    ),
    "afdd537a": Fill(
        correct=_POSE_AT + (
            "    wrap = labkit.geometry.wrap_angle\n"
            "    u = (t - t0) / (t1 - t0)\n"
            "    x = p0[0] + u * (p1[0] - p0[0])\n"
            "    y = p0[1] + u * (p1[1] - p0[1])\n"
            "    return np.array([x, y, wrap(p0[2] + u * wrap(p1[2] - p0[2]))])\n"),
        # theta interpolated like x and y: from 170 deg to -170 deg the long way, through 0
        mistake=_POSE_AT + (
            "    u = (t - t0) / (t1 - t0)\n"
            "    return np.array([p0[k] + u * (p1[k] - p0[k]) for k in range(3)])\n"),
        hint="the short way round",
    ),
}
