"""``vilma report``'s folder: claimed as a run's, never the recording's own."""

from __future__ import annotations

from vilma.app.cli import main


def test_a_report_never_replaces_a_run_or_an_earlier_report_unasked(tmp_path, capsys):
    s = tmp_path / "s.yaml"
    s.write_text("task: {speed: 5}\ninitial: {speed: 5}\nduration: 1\n")
    run = tmp_path / "r1"
    assert main(["run", str(s), "--out", str(run), "-q"]) == 0
    scorecard = (run / "metrics.json").read_bytes()
    for more in ([], ["--overwrite"]):  # the run's own folder: refused, whatever is asked
        assert main(["report", str(run / "run.mcap"), "--out", str(run), "-q", *more]) == 2
        assert capsys.readouterr().err == (f"vilma report: error: {run}: holds the recording run.mcap; its report goes "
                                           f"in a folder of its own (by default {run / 'run-report'}): choose another "
                                           "--out\n")
    assert (run / "metrics.json").read_bytes() == scorecard
    assert main(["report", str(run), "-q"]) == 0
    (run / "run-report" / "notes.txt").write_text("mine")
    assert main(["report", str(run), "-q"]) == 2
    assert capsys.readouterr().err.startswith(f"vilma report: error: {run / 'run-report'}: holds an earlier run or "
                                              "other files (cross_track.png, ")
    assert main(["report", str(run), "-q", "--overwrite"]) == 0
    assert (run / "run-report" / "notes.txt").read_text() == "mine" and (run / "run-report" / "metrics.json").is_file()
    assert (run / "metrics.json").read_bytes() == scorecard


def test_export_and_replay_take_a_run_folder_and_refuse_one_without_a_recording_or_with_an_empty_one(tmp_path, capsys):
    s = tmp_path / "s.yaml"
    s.write_text("task: {speed: 5}\ninitial: {speed: 5}\nduration: 1\n")
    run = tmp_path / "r"
    assert main(["run", str(s), "--out", str(run), "-q"]) == 0
    assert main(["export", "rosbag2", str(run), str(tmp_path / "bag")]) == 0  # the folder: its run.mcap
    assert (tmp_path / "bag" / "metadata.yaml").is_file()
    bare = tmp_path / "bare"
    assert main(["run", str(s), "--out", str(bare), "-q", "--no-record"]) == 0
    cut = tmp_path / "cut.mcap"  # a recording whose writer died before its first chunk: the header alone
    cut.write_bytes((run / "run.mcap").read_bytes()[:64])
    capsys.readouterr()
    for args, error in ((["report", str(bare)], f"{bare}: holds no run.mcap (a run with --no-record or --cars "),
                        (["export", "rosbag2", str(cut), str(tmp_path / "b2")],
                         f"{cut}: holds no messages (cut short before its first chunk)")):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"vilma {args[0]}: error: {error}") and err.count("\n") == 1
