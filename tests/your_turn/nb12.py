"""Fill-ins for notebooks/12_tracking_people.ipynb: the process noise of the constant-velocity model, the
assignment by brute force."""

from tests.your_turn import Fill

_Q = "def process_noise(dt, q):\n"
_BEST = "def best_assignment(cost):\n"

FILLS = {
    "process-noise": Fill(
        correct=_Q + (
            "    Q = np.zeros((4, 4))\n"
            "    for p, v in ((0, 2), (1, 3)):\n"
            "        Q[p, p], Q[p, v], Q[v, p], Q[v, v] = dt**3 / 3, dt**2 / 2, dt**2 / 2, dt\n"
            "    return q * Q\n"),
        # the position term of a constant acceleration (dt^2/2) instead of the integral of white noise
        mistake=_Q + (
            "    Q = np.zeros((4, 4))\n"
            "    for p, v in ((0, 2), (1, 3)):\n"
            "        Q[p, p], Q[p, v], Q[v, p], Q[v, v] = dt**2 / 2, dt**2 / 2, dt**2 / 2, dt\n"
            "    return q * Q\n"),
        hint="the x block",
    ),
    "best-assignment": Fill(
        correct=_BEST + (
            "    import itertools\n"
            "    n = len(cost)\n"
            "    best = min(itertools.permutations(range(n)), key=lambda p: sum(cost[i][p[i]] for i in range(n)))\n"
            "    return [(i, best[i]) for i in range(n)]\n"),
        # greedy: each row takes its cheapest free column, in order
        mistake=_BEST + (
            "    free, pairs = set(range(len(cost))), []\n"
            "    for i, row in enumerate(cost):\n"
            "        j = min(free, key=lambda c: row[c])\n"
            "        free.discard(j)\n"
            "        pairs.append((i, j))\n"
            "    return pairs\n"),
        hint="the total decides",
    ),
}
