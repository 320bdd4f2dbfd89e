"""`bench run --shard K/N` + `bench merge`: the shards of a run, merged, are the unsharded run."""
import json

from bench.__main__ import main
from bench.results import comparable, read_rows

ARGS = ["--algo", "fake_map", "--repeats", "3", "--jobs", "1", "--no-progress", "--no-figures"]


def test_merged_shards_equal_the_unsharded_run(tiny, tmp_path, capsys):
    assert main(["run", "--world", tiny, *ARGS, "--out", str(tmp_path / "whole")]) == 0
    for k in (1, 2, 3):
        assert main(["run", "--world", tiny, *ARGS, "--shard", f"{k}/3", "--out", str(tmp_path / f"s{k}")]) == 0
    sizes = [len(read_rows(tmp_path / f"s{k}")) for k in (1, 2, 3)]
    assert sum(sizes) == 3 and all(s == 1 for s in sizes)
    capsys.readouterr()
    assert main(["merge", *(str(tmp_path / f"s{k}") for k in (3, 1, 2)), "--out", str(tmp_path / "m"),
                 "--no-figures"]) == 0
    assert comparable(read_rows(tmp_path / "m")) == comparable(read_rows(tmp_path / "whole"))
    for row in read_rows(tmp_path / "m"):
        assert (tmp_path / "m" / row["map_file"]).is_file() and row["host"] and row["cpu"]
    run = json.loads((tmp_path / "m" / "run.json").read_text())
    assert run["spec"]["shard"] == [1, 1] and run["missing_shards"] == []
    assert "fake_map" in (tmp_path / "m" / "summary.md").read_text()


def test_partial_merge_is_completed_by_resume(tiny, tmp_path, capsys):
    for k in (1, 2):
        assert main(["run", "--world", tiny, *ARGS, "--shard", f"{k}/3", "--out", str(tmp_path / f"s{k}")]) == 0
    capsys.readouterr()
    assert main(["merge", str(tmp_path / "s1"), str(tmp_path / "s2"), "--out", str(tmp_path / "m"),
                 "--no-figures"]) == 0
    assert "shards 3 missing" in capsys.readouterr().out
    assert main(["run", "--resume", str(tmp_path / "m"), "--jobs", "1", "--no-progress", "--no-figures"]) == 0
    assert len(read_rows(tmp_path / "m")) == 3


def test_merge_refuses_doubles_and_strangers(tiny, tmp_path, capsys):
    assert main(["run", "--world", tiny, *ARGS, "--shard", "1/2", "--out", str(tmp_path / "a")]) == 0
    assert main(["run", "--world", tiny, *ARGS[:3], "2", *ARGS[4:], "--shard", "2/2",
                 "--out", str(tmp_path / "b")]) == 0
    capsys.readouterr()
    assert main(["merge", str(tmp_path / "a"), str(tmp_path / "a"), "--out", str(tmp_path / "m")]) == 2
    assert "shard 1/2 again" in capsys.readouterr().err
    assert main(["merge", str(tmp_path / "a"), str(tmp_path / "b"), "--out", str(tmp_path / "m2")]) == 2
    assert "a shard of another run" in capsys.readouterr().err
    assert main(["run", "--world", tiny, *ARGS, "--shard", "3/2", "--out", str(tmp_path / "c")]) == 2
    assert "--shard" in capsys.readouterr().err
