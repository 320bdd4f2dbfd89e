"""`bench speed` prints a table of real-time factors (its numbers are not checked: timings are
for benchmark runs, not tests)."""
from bench.__main__ import main


def test_speed_table_has_a_row_per_world_and_a_column_per_algorithm(tiny, capsys):
    assert main(["speed", "--world", tiny, "--algo", "oracle", "--runs", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("CPU: ")
    assert out[2] == "| world | log (s) | simulator | oracle |"
    row = out[4].split("|")
    assert row[1].strip() == "tiny" and row[3].strip().endswith(")") and "x (" in row[4]
