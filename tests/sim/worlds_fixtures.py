"""Small hand-made worlds for the sim tests (built directly, no YAML)."""
import numpy as np

from worlds.model import Wall, World


def square_room(size: float = 4.0, route=None, start=(1.0, 2.0, 0.0)) -> World:
    """A closed square room, wall centre lines on [0, size]^2, thickness 0.1 m, so the
    inner wall faces are at 0.05 and size - 0.05."""
    pts = np.array([[0, 0], [size, 0], [size, size], [0, size], [0, 0]], float)
    return World("square", (Wall(pts, 0.1),), start=np.asarray(start, float),
                 route=None if route is None else np.asarray(route, float))


def walled_room() -> World:
    """A 4 m room split by a wall x = 2 from y = 0 to 3.2: the route's second waypoint lies
    straight behind it, so the robot drives into the wall."""
    outer = Wall(np.array([[0, 0], [4, 0], [4, 4], [0, 4], [0, 0]], float), 0.1)
    inner = Wall(np.array([[2, 0], [2, 3.2]], float), 0.1)
    return World("walled", (outer, inner), start=np.array([1.0, 1.0, 0.0]),
                 route=np.array([[1.5, 1.0], [3.0, 1.0]]))
