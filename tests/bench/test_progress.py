import io

from bench.progress import Progress, format_seconds


class _Tty(io.StringIO):
    def isatty(self):
        return True


def test_plain_lines_without_tty():
    s = io.StringIO()
    p = Progress(4, already=2, stream=s)
    p.advance("w/pf/0")
    p.advance("w/gn/0", ok=False)
    p.close()
    lines = s.getvalue().splitlines()
    assert len(lines) == 2
    assert "3/6" in lines[0] and "w/pf/0" in lines[0] and "ETA" in lines[0]
    assert "4/6 1 failed" in lines[1] and "FAILED" in lines[1]
    assert "\r" not in s.getvalue()


def test_single_rewritten_line_on_tty():
    s = _Tty()
    p = Progress(2, stream=s)
    p.note("recording w")
    p.advance("w/pf/0")
    p.advance("w/pf/1")
    p.close()
    text = s.getvalue()
    assert text.count("\r") == 3 and text.endswith("\n") and text.count("\n") == 1
    assert "2/2" in text


def test_format_seconds():
    assert format_seconds(12.3) == "0:12"
    assert format_seconds(3725) == "1:02:05"
    assert format_seconds(float("nan")) == "?"
