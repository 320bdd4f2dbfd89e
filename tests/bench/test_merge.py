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


def _listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def _two_shards(tiny, tmp_path):
    for k in (1, 2):
        assert main(["run", "--world", tiny, *ARGS, "--shard", f"{k}/2", "--out",
                     str(tmp_path / f"s{k}")]) == 0


def test_a_map_file_leading_out_of_the_shard_is_refused(tiny, tmp_path, capsys):
    """A row's map file that resolves outside its shard (here through a symlinked folder):
    nothing is copied from there, nothing is written."""
    _two_shards(tiny, tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "0.npz").write_bytes(b"secret")
    (elsewhere / "1.npz").write_bytes(b"secret")
    (elsewhere / "2.npz").write_bytes(b"secret")
    folder = tmp_path / "s2" / "maps" / "tiny" / "fake_map"
    for f in folder.iterdir():
        f.unlink()
    folder.rmdir()
    folder.symlink_to(elsewhere)
    capsys.readouterr()
    assert main(["merge", str(tmp_path / "s1"), str(tmp_path / "s2"), "--out",
                 str(tmp_path / "m"), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "leads outside the shard folder" in err[0], err
    assert f"{tmp_path / 's2' / 'results.json'}: map_file of tiny/fake_map/" in err[0]
    assert not (tmp_path / "m" / "results.json").exists() and not (tmp_path / "m" / "maps").exists()


def test_merge_writes_nothing_outside_out(tiny, tmp_path, capsys):
    """--out whose maps folder is a symlink to another folder: every target resolves outside
    --out, so the merge refuses before copying (the victim folder stays as it was)."""
    _two_shards(tiny, tmp_path)
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "keep.txt").write_text("mine\n")
    out = tmp_path / "m"
    out.mkdir()
    (out / "maps").symlink_to(victim)
    capsys.readouterr()
    assert main(["merge", str(tmp_path / "s1"), str(tmp_path / "s2"), "--out", str(out),
                 "--no-figures"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "outside the folder" in err[0] and str(out) in err[0], err
    assert _listing(victim) == ["keep.txt"]
    assert not (out / "results.json").exists() and not (out / "run.json").exists()


def test_a_row_map_file_of_dot_dot_is_refused_by_the_reader(tiny, tmp_path, capsys):
    _two_shards(tiny, tmp_path)
    results = tmp_path / "s2" / "results.json"
    data = json.loads(results.read_text())
    data["rows"][0]["map_file"] = "../X"
    results.write_text(json.dumps(data))
    (tmp_path / "X").write_bytes(b"outside")
    capsys.readouterr()
    assert main(["merge", str(tmp_path / "s1"), str(tmp_path / "s2"), "--out",
                 str(tmp_path / "m"), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"error: {results}: rows[0].map_file: '../X' is not a path inside the run "
                   "folder (parts of letters, digits and _ . + -, separated by /)")
    assert not (tmp_path / "m" / "X").exists() and not (tmp_path / "m" / "results.json").exists()


def test_merge_into_a_relative_folder(tiny, tmp_path, capsys, monkeypatch):
    _two_shards(tiny, tmp_path)
    monkeypatch.chdir(tmp_path)
    assert main(["merge", "s1", "s2", "--out", "m", "--no-figures"]) == 0
    assert len(read_rows(tmp_path / "m")) == 3
    assert (tmp_path / "m" / "run.json").is_file() and not (tmp_path / "m" / "m").exists()
