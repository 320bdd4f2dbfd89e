from bench.figures import median_row


def _r(rep, f1, status="ok"):
    return {"world": "w", "algo": "pf", "repeat": rep, "status": status, "f1": f1,
            "map_file": f"maps/w/pf/{rep}.npz"}


def test_median_row_by_f1_lower_median():
    rows = [_r(0, 0.9), _r(1, 0.1), _r(2, 0.5), _r(3, None, "failed")]
    assert median_row(rows)["repeat"] == 2
    rows.append(_r(4, 0.7))
    assert median_row(rows)["repeat"] == 2  # 0.1 0.5 | 0.7 0.9: the lower middle
    assert median_row([_r(0, None, "failed")]) is None
