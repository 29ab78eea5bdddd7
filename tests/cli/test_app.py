from typer.testing import CliRunner

from agvnav.cli import app

runner = CliRunner()


def test_help_on_root_and_bench():
    for args in ([], ["--help"], ["bench", "--help"]):
        result = runner.invoke(app, args)
        assert "agvnav" in result.output or "Benchmarks" in result.output
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and "agvnav" in result.output
