from typer.testing import CliRunner

from agvnav.cli import app

runner = CliRunner()


def test_help_on_root_and_bench():
    for args in ([], ["--help"], ["bench", "--help"]):
        result = runner.invoke(app, args)
        assert "agvnav" in result.output or "Benchmarks" in result.output
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and "agvnav" in result.output


def _exit_code(argv, capsys):
    import pytest

    from agvnav.cli import main

    with pytest.raises(SystemExit) as info:
        main(argv)
    return info.value.code, capsys.readouterr()


def test_usage_errors_are_one_line_with_exit_code_2(capsys):
    for argv in (
        ["frobnicate"],
        ["bench", "nonsense"],
        ["demo", "--bogus"],
        ["bench", "triangulation", "--seed", "-1"],
    ):
        code, out = _exit_code(argv, capsys)
        assert code == 2, argv
        lines = [ln for ln in out.err.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("error: "), (argv, out.err)


def test_help_and_version_exit_zero(capsys):
    assert _exit_code(["--help"], capsys)[0] == 0
    code, out = _exit_code(["--version"], capsys)
    assert code == 0 and "agvnav" in out.out


def test_no_arguments_prints_help_and_exits_2(capsys):
    code, out = _exit_code([], capsys)
    assert code == 2 and "Usage" in out.out
