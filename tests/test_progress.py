"""The stderr progress line: shown on a terminal, silent on a pipe or with --quiet."""

import io
import sys

import pytest

from jaxgwo._progress import Progress, format_duration
from jaxgwo.cli._main import build_parser, main


class FakeTTY(io.StringIO):
    def isatty(self):
        return True


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def test_line_on_a_terminal_with_rate_and_eta():
    out, clock = FakeTTY(), Clock()
    with Progress(10, "montecarlo", "seeds", stream=out, clock=clock, width=10) as bar:
        clock.t += 3.0          # the first chunk: compilation
        bar.update(2)
        clock.t += 1.0          # 4 more seeds in 1 s: 4 seeds/s, 4 left -> ETA 0:01
        bar.update(6, "chunk 2")
        clock.t += 1.0
        bar.update(10)
    text = out.getvalue()
    frames = text.split("\r")[1:]
    assert frames[0].startswith("montecarlo [..........] 0/10 seeds  ETA ?")
    assert frames[1].startswith("montecarlo [##........] 2/10 seeds  ETA ?  elapsed 0:03")
    assert frames[2].startswith("montecarlo [######....] 6/10 seeds  4 seeds/s  ETA 0:01  "
                                "elapsed 0:04  chunk 2")
    assert frames[3].startswith("montecarlo [##########] 10/10 seeds  4 seeds/s  ETA 0:00")
    assert text.endswith("\n") and text.count("\n") == 1
    # a shorter line wipes the tail of the longer one before it
    assert len(frames[3].rstrip("\n")) >= len(frames[2])


def test_stages_without_eta():
    out, clock = FakeTTY(), Clock()
    with Progress(3, "identify", "stages", stream=out, clock=clock, eta=False) as bar:
        bar.update(0, "lateral: frequency response")
        clock.t += 2.0
        bar.update(1, "optimising")
    frames = out.getvalue().split("\r")[1:]
    assert frames[2].rstrip() == ("identify [##########....................] 1/3 stages  "
                                  "elapsed 0:02  optimising")
    assert "ETA" not in out.getvalue() and "/s" not in out.getvalue()


@pytest.mark.parametrize("stream, quiet", [(io.StringIO(), False), (FakeTTY(), True)])
def test_silent_on_a_pipe_or_when_quiet(stream, quiet):
    with Progress(5, "x", stream=stream, quiet=quiet) as bar:
        for i in range(5):
            bar.advance(1, f"step {i}")
    assert stream.getvalue() == ""
    assert bar.done == 5


def test_format_duration():
    assert format_duration(0.4) == "0:00"
    assert format_duration(75) == "1:15"
    assert format_duration(3725) == "1:02:05"
    assert format_duration(float("inf")) == "?" and format_duration(float("nan")) == "?"


def test_global_and_subcommand_quiet_are_the_same_flag():
    p = build_parser()
    assert p.parse_args(["--quiet", "montecarlo"]).global_quiet is True
    assert p.parse_args(["montecarlo", "--quiet"]).quiet is True


MC = ["montecarlo", "--seeds", "3", "--chunk", "2", "--wolves", "6", "--iterations", "4",
      "--devices", "1"]


def test_montecarlo_progress_per_chunk_on_a_tty_only(monkeypatch, capsys):
    tty = FakeTTY()
    monkeypatch.setattr(sys, "stderr", tty)
    assert main(MC) == 0
    frames = tty.getvalue().split("\r")[1:]
    assert [f.split("]")[1].split("seeds")[0].strip() for f in frames] == ["0/3", "2/3", "3/3"]
    assert tty.getvalue().endswith("\n")
    assert "3 seeds (igwo" in capsys.readouterr().out
    for argv in (["--quiet", *MC], [*MC, "--quiet"]):  # quiet: neither progress nor summary
        tty = FakeTTY()
        monkeypatch.setattr(sys, "stderr", tty)
        assert main(argv) == 0
        assert tty.getvalue() == ""
        assert capsys.readouterr().out == ""
    pipe = io.StringIO()  # not a terminal: no progress, the summary still printed
    monkeypatch.setattr(sys, "stderr", pipe)
    assert main(MC) == 0
    assert pipe.getvalue() == ""
    assert "success within" in capsys.readouterr().out


def test_compare_progress_per_run(monkeypatch, capsys):
    tty = FakeTTY()
    monkeypatch.setattr(sys, "stderr", tty)
    assert main(["compare", "--seeds", "2", "--wolves", "6", "--iterations", "3", "--dim", "2",
                 "--problems", "F1", "--variants", "gwo,igwo"]) == 0
    frames = tty.getvalue().split("\r")[1:]
    assert "0/2 runs" in frames[0] and "1/2 runs" in frames[1] and "2/2 runs" in frames[2]
    assert "F1 sphere gwo median" in frames[1] and "F1 sphere igwo median" in frames[2]
    assert "| F1 sphere | igwo |" in capsys.readouterr().out
