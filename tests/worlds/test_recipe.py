"""docs/extending.md's world recipe is a valid world, as written: it loads, and a covering
route is planned for it (it has none of its own)."""
import re
from pathlib import Path

import worlds

RECIPE = Path(__file__).resolve().parents[2] / "docs" / "extending.md"


def test_the_world_recipe_loads_and_gets_a_route(tmp_path):
    section = RECIPE.read_text().split("## Adding a world", 1)[1].split("\n## ", 1)[0]
    text = re.search(r"```yaml\n(.*?)```", section, re.S).group(1)
    path = tmp_path / "my_room.yaml"
    path.write_text(text)
    world = worlds.load_world(path)
    assert world.name == "my_room" and world.route is None
    route = worlds.route_for(world)
    assert len(route) >= 2
