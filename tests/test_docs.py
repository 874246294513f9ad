"""Every command shown in README.md and docs/*.md runs, in a quick form, so the docs cannot rot.

Commands are the lines of the ```sh blocks that start with ``mitsonar``, ``python``,
``.venv/bin/python`` or ``make`` (a trailing backslash continues a line, ``#`` starts a
comment); any other line in such a block, or a command in a block of another language, fails.
Every ``mitsonar`` command must parse with ``mitsonar.cli.build_parser()`` and every script
command with the script's own parser, so a renamed option fails here. Every command must have
a quick form in ``QUICK`` (options that make it small; outputs land in a temporary folder), and
runs in it with exit status 0, in ``QUICK``'s order (later commands read what earlier ones
wrote).

Not run here:

* ``make demo`` and ``make test``: they build the virtual environment and run this suite. The
  Makefile is checked to have every documented target, and the demo's command to be the one
  the README shows (which runs here).
* the experiment scripts: ``tests/test_experiments.py`` runs each in its quick setting
  (checked here); their documented options are parsed here.

The benchmark's quick form (about 65 s) runs in its own test, marked slow. Beside the
commands: the Python blocks run (after the commands, which write the dataset they read), the
TOML blocks load as a ``SonarConfig``, the XML blocks as materials of a scene, links to pages,
anchors and images resolve, and the options named in the README's command table exist.
"""

import argparse
import importlib.util
import re
import shlex
import subprocess
import sys

import pytest
from helpers import ROOT

import mitsonar
from mitsonar.cli import build_parser

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
PREFIXES = ("mitsonar", "python", ".venv/bin/python", "make")
LANGUAGES = {"sh", "python", "toml", "xml"}
#: Folders the commands read from, linked into the temporary working folder.
LINKED = ("scenes", "experiments", "benchmarks")
#: Stands for "run by tests/test_experiments.py, only parsed here".
BY_TEST_EXPERIMENTS = "tests/test_experiments.py"
SLOW_SCRIPTS = {"benchmarks/run.py"}

#: Documented command -> options of its quick form (None: a flag), in the order they run.
QUICK: list[tuple[str, dict | str]] = [
    ("mitsonar scan scenes/room_glass/scene.xml --pose 0,0,0 --fov 60x40 --step 5 --out out/demo",
     {"--fov": "20x10", "--step": "10"}),
    ("mitsonar map repeated scenes/office/scene.xml --broadband --out out/office_map",
     {"--frames": "1", "--step": "20"}),
    ("mitsonar map repeated scenes/workshop/scene.xml --scan imaging --chirp --broadband --out "
     "out/workshop_images", {"--frames": "1"}),
    ("mitsonar map surfel scenes/structure/scene.xml --preset paper --out out/structure_surfels",
     {"--duration": "0.3", "--width": "160", "--spp": "1"}),
    ("mitsonar evaluate out/demo/points.ply scenes/room_glass/scene.xml", {"--spacing": "0.1"}),
    ("mitsonar dataset render scenes/office/scene.xml --out out/office_ds --period 1 --step 10 "
     "--width 400 --spp 16 --workers 2",
     {"--samples": "1", "--step": "20", "--width": "32", "--spp": "1", "--workers": "1"}),
    ("mitsonar dataset render scenes/workshop/scene.xml --out out/workshop_images --scan image "
     "--broadband --chirp --period 0.2", {"--samples": "1", "--width": "32", "--spp": "1"}),
    ("mitsonar dataset info out/office_ds", {}),
    ("mitsonar dataset export out/office_ds --out out/office_ds.mcap", {}),
    ("mitsonar map surfel room_glass --duration 20 --out out/room_surfels --record "
     "out/room_surfels.mcap",
     {"--duration": "0.3", "--width": "120", "--spp": "1"}),
    ("mitsonar scenes", {}),
    ("mitsonar scan room_glass --step 20 --out out/scan", {"--fov": "20x10"}),
    ("mitsonar array design --out out/layout.json", {"--generations": "2", "--population": "8"}),
    ("mitsonar array plot --out out/array", {}),
    (".venv/bin/python scenes/generate.py", {"--out": "out/scenes", "--only": "room_glass"}),
    (".venv/bin/python scenes/generate.py --only office --out out/scenes", {}),
    (".venv/bin/python scenes/generate.py --varied 10 --out out/varied", {"--varied": "1"}),
    (".venv/bin/python scenes/generate.py --lighting ceiling --out out/ceiling",
     {"--only": "room_glass"}),
    (".venv/bin/python scenes/generate.py --varied 10 --lighting ceiling --out out/varied_ceiling",
     {"--varied": "1"}),
    (".venv/bin/python benchmarks/run.py", {"--quick": None}),
    (".venv/bin/python benchmarks/run.py --quick", {}),
    *[(f".venv/bin/python experiments/{name}.py {quick}--out out/{name}", BY_TEST_EXPERIMENTS)
      for name in ("ofdm_motion", "material_reflectivity", "comparison", "small_objects",
                   "shadow_lines", "speed_accuracy") for quick in ("", "--quick ")],
    (".venv/bin/python experiments/wall_validation.py --out out/wall_validation",
     BY_TEST_EXPERIMENTS),
    (".venv/bin/python experiments/imaging.py --stride 20 --out out/imaging", BY_TEST_EXPERIMENTS),
    (".venv/bin/python experiments/imaging.py --quick --out out/imaging", BY_TEST_EXPERIMENTS),
    (".venv/bin/python experiments/incidence.py --period 2 --out out/incidence",
     BY_TEST_EXPERIMENTS),
    (".venv/bin/python experiments/incidence.py --quick --out out/incidence", BY_TEST_EXPERIMENTS),
    (".venv/bin/python experiments/incidence.py --scenes room_glass --presets "
     "default,default_broadband,default_no_sidelobe_check --period 4 --out out/incidence_why",
     BY_TEST_EXPERIMENTS),
    (".venv/bin/python experiments/surfel_coverage.py --duration 8 --out out/surfel_coverage",
     BY_TEST_EXPERIMENTS),
    (".venv/bin/python experiments/surfel_coverage.py --quick --out out/surfel_coverage",
     BY_TEST_EXPERIMENTS),
]


def fenced_blocks(path) -> list[tuple[str, str]]:
    """(language, text) of every fenced block of a Markdown page."""
    blocks, language, lines = [], None, []
    for line in path.read_text().splitlines():
        if line.startswith("```"):
            if language is None:
                language, lines = line[3:].strip(), []
            else:
                blocks.append((language, "\n".join(lines)))
                language = None
        elif language is not None:
            lines.append(line)
    assert language is None, f"{path.name}: unclosed code block"
    return blocks


def shell_lines(text: str) -> list[list[str]]:
    """Words of each command line (continuations joined, comments dropped)."""
    lines = text.replace("\\\n", " ").splitlines()
    return [words for words in (shlex.split(line, comments=True) for line in lines) if words]


def documented() -> dict[str, tuple[list[str], str]]:
    """Every documented command, normalised: its words and the page that shows it."""
    found = {}
    for page in PAGES:
        for language, text in fenced_blocks(page):
            assert language in LANGUAGES, f"{page.name}: code block of language '{language}'"
            if language != "sh":
                for line in text.splitlines():
                    assert not line.startswith(tuple(p + " " for p in PREFIXES)), (
                        f"{page.name}: command outside a sh block: {line}")
                continue
            for words in shell_lines(text):
                assert words[0] in PREFIXES, f"{page.name}: not a command: {' '.join(words)}"
                found.setdefault(" ".join(words), (words, page.name))
    return found


def quick_argv(words: list[str], options: dict) -> list[str]:
    argv = list(words)
    for option, value in options.items():
        if option in argv:
            if value is not None:
                argv[argv.index(option) + 1] = value
        else:
            argv += [option] if value is None else [option, value]
    return argv


class Parsed(Exception):
    pass


def parse_script(words: list[str], monkeypatch) -> None:
    """Parse a script command with the script's own parser (its main stops after parsing)."""
    script = ROOT / words[1]
    spec = importlib.util.spec_from_file_location(f"docs_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)  # dataclasses look their module up
    spec.loader.exec_module(module)
    parse = argparse.ArgumentParser.parse_args

    def parse_then_stop(self, args=None, namespace=None):
        raise Parsed(parse(self, args, namespace))

    with monkeypatch.context() as m:
        m.setattr(argparse.ArgumentParser, "parse_args", parse_then_stop)
        with pytest.raises(Parsed):
            module.main(words[2:])


def test_every_command_parses_and_has_a_quick_form(monkeypatch):
    commands = documented()
    table = dict(QUICK)
    assert len(table) == len(QUICK), "a command is listed twice in QUICK"
    missing = [f"{page}: {key}" for key, (words, page) in commands.items()
               if key not in table and words[0] != "make"]  # make: test_makefile_targets
    assert not missing, "documented commands without a quick form in QUICK:\n" + "\n".join(missing)
    stale = [key for key in table if key not in commands]
    assert not stale, "QUICK lists commands no page shows:\n" + "\n".join(stale)
    experiments_test = (ROOT / BY_TEST_EXPERIMENTS).read_text()
    for key, (words, page) in commands.items():
        if words[0] == "make":
            continue
        try:
            if words[0] == "mitsonar":
                build_parser().parse_args(words[1:])
            else:
                parse_script(words, monkeypatch)
        except SystemExit:
            pytest.fail(f"{page}: `{key}` does not parse")
        if table[key] == BY_TEST_EXPERIMENTS:
            stem = words[1].removeprefix("experiments/").removesuffix(".py")
            assert f'run_experiment("{stem}"' in experiments_test, f"nothing runs {key}"


def test_makefile_targets_and_demo():
    makefile = (ROOT / "Makefile").read_text()
    targets = set(re.findall(r"^([a-z]+):", makefile, re.M))
    for words, page in documented().values():
        if words[0] == "make":
            assert set(words[1:]) <= targets, f"{page}: {' '.join(words)}"
    recipe = re.search(r"^demo:.*\n((?:\t.*\n)+)", makefile, re.M).group(1)
    demo = " ".join(recipe.replace("\\\n", " ").split()).replace("$(VENV)/bin/", "")
    assert demo.replace("$(OUT)", "out") in documented()


def quick_commands(slow: bool) -> list[list[str]]:
    """Distinct quick forms of the documented commands that run here, in QUICK's order."""
    commands, runs = documented(), []
    for key, options in QUICK:
        if key not in commands or not isinstance(options, dict):
            continue
        words = quick_argv(commands[key][0], options)
        if words[1] == "scenes/generate.py" or words[1:3] == ["array", "design"]:
            # without --out these rewrite the shipped scenes or array layout
            assert "--out" in words and words[words.index("--out") + 1].startswith("out/"), key
        if (words[1] in SLOW_SCRIPTS) == slow and words not in runs:
            runs.append(words)
    return runs


def run_all(commands: list[list[str]], folder) -> list[str]:
    for name in LINKED:
        if not (folder / name).exists():
            (folder / name).symlink_to(ROOT / name)
    failures = []
    for words in commands:
        head = [sys.executable, "-m", "mitsonar"] if words[0] == "mitsonar" else [sys.executable]
        done = subprocess.run(head + words[1:], cwd=folder, capture_output=True, text=True)
        if done.returncode != 0:
            failures.append(f"{' '.join(words)}: exit {done.returncode}\n{done.stderr[-2000:]}")
    return failures


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A folder where every quick command has run: (folder, failures)."""
    folder = tmp_path_factory.mktemp("docs")
    return folder, run_all(quick_commands(slow=False), folder)


def test_every_command_runs_in_its_quick_form(workdir):
    _, failures = workdir
    assert not failures, "\n\n".join(failures)


@pytest.mark.slow
def test_the_benchmark_runs_in_its_quick_form(tmp_path):
    failures = run_all(quick_commands(slow=True), tmp_path)
    assert not failures, "\n\n".join(failures)


def test_python_toml_and_xml_blocks(workdir, monkeypatch):
    folder, _ = workdir
    monkeypatch.chdir(folder)
    for page in PAGES:
        for index, (language, text) in enumerate(fenced_blocks(page)):
            if language == "python":
                exec(compile(text, f"{page.name} block {index}", "exec"), {"__name__": "docs"})
            elif language == "toml":
                (folder / "block.toml").write_text(text)
                assert isinstance(mitsonar.SonarConfig.from_toml(folder / "block.toml"),
                                  mitsonar.SonarConfig)
            elif language == "xml":
                material = re.search(r'<bsdf type="acoustic" id="(\w+)"', text).group(1)
                (folder / "block.xml").write_text(
                    f'<scene version="3.0.0">{text}<shape type="rectangle">'
                    f'<ref id="{material}"/></shape></scene>')
                scene = mitsonar.load_scene(folder / "block.xml")
                assert [m.name for m in scene.materials] == [material]


def slug(heading: str) -> str:
    """GitHub's anchor of a heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_links_and_images_resolve():
    broken = []
    for page in PAGES:
        text = page.read_text()
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if target.startswith(("http://", "https://")):
                continue
            path, _, anchor = target.partition("#")
            linked = (page.parent / path) if path else page
            if not linked.exists():
                broken.append(f"{page.name}: {target}")
            elif anchor:
                headings = re.findall(r"^#+ (.+)$", linked.read_text(), re.M)
                if anchor not in map(slug, headings):
                    broken.append(f"{page.name}: {target} (no such heading)")
    assert not broken, "\n".join(broken)


def test_readme_command_table_names_real_options():
    parser = build_parser()
    rows = re.findall(r"^\| `mitsonar ([^`]+)` \|(.*)$", (ROOT / "README.md").read_text(), re.M)
    assert len(rows) >= 8
    for command, rest in rows:
        sub = parser
        for word in command.split():
            actions = [a for a in sub._actions if isinstance(a, argparse._SubParsersAction)]
            if not actions or word not in actions[0].choices:
                break
            sub = actions[0].choices[word]
        assert sub is not parser, command
        known = {s for a in sub._actions for s in a.option_strings}
        named = set(re.findall(r"(?<![\w-])--[a-z][a-z-]*", rest))
        assert named <= known, f"mitsonar {command}: {sorted(named - known)}"
