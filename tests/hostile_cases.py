"""The bad inputs tried on the `nxtnav` command, as a new user (or a hostile one) would type them.

Each case is one command line run in a scratch folder that holds the files the cases name (broken
maps, a map cut in two, a huge map, ...). A case is handled cleanly when the exit code is the expected
one (2 bad input, 1 plan or mission failed, 0 where the input is odd but usable) and, for a failure,
stderr is exactly one line ``nxtnav: ...`` with no traceback. ``tests/test_cli_hostile_cases.py`` runs
every case; ``docs/hostile_inputs.py`` runs them through the console script and prints the table.
"""

from __future__ import annotations

import os
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["BINARY", "FILES", "FOLDERS", "Case", "cases", "prepare"]

FILES = {
    "split.yaml": "name: split\nboundary: [[0, 0], [100, 0], [100, 60], [0, 60]]\n"
                  "obstacles:\n  - [[45, 2], [55, 2], [55, 58], [45, 58]]\nstart: [20, 30]\ntarget: [80, 30]\n",
    "huge.yaml": "name: huge\nboundary: [[0, 0], [900000, 0], [900000, 900000], [0, 900000]]\n"
                 "start: [50, 50]\ntarget: [100, 100]\n",
    "far.yaml": "boundary: [[0, 0], [1.0e+300, 0], [1.0e+300, 1.0e+300], [0, 1.0e+300]]\n",
    "bigint.yaml": "boundary: [[0, 0], [" + "9" * 400 + ", 0], [10, 10]]\n",
    "syntax.yaml": "boundary: [[0, 0], [10, 0]\n",
    "noboundary.yaml": "name: nothing\n",
    "two.yaml": "boundary: [[0, 0], [10, 0]]\n",
    "bowtie.yaml": "boundary: [[0, 0], [10, 10], [10, 0], [0, 10]]\n",
    "flat.yaml": "boundary: [[0, 0], [5, 0], [10, 0]]\n",
    "text.yaml": "boundary: [[0, 0], [ten, 0], [10, 10]]\n",
    "nan.yaml": "boundary: [[0, 0], [.nan, 0], [10, 10]]\n",
    "inf.yaml": "boundary: [[0, 0], [.inf, 0], [10, 10]]\n",
    "bool.yaml": "boundary: [[0, 0], [true, 0], [10, 10]]\n",
    "point3.yaml": "boundary: [[0, 0, 0], [10, 0], [10, 10]]\n",
    "obstacle_out.yaml": "boundary: [[0, 0], [50, 0], [50, 50], [0, 50]]\n"
                         "obstacles:\n  - [[60, 60], [70, 60], [70, 70]]\n",
    "obstacles_overlap.yaml": "boundary: [[0, 0], [50, 0], [50, 50], [0, 50]]\nobstacles:\n"
                              "  - [[10, 10], [30, 10], [30, 30], [10, 30]]\n"
                              "  - [[20, 20], [40, 20], [40, 40], [20, 40]]\n",
    "start_out.yaml": "boundary: [[0, 0], [50, 0], [50, 50], [0, 50]]\nstart: [80, 80]\n",
    "target_wall.yaml": "boundary: [[0, 0], [50, 0], [50, 50], [0, 50]]\nobstacles:\n"
                        "  - [[20, 20], [30, 20], [30, 30], [20, 30]]\ntarget: [25, 25]\n",
    "empty.yaml": "",
    "list.yaml": "- 1\n- 2\n",
    "scalar.yaml": "42\n",
    "nopreset.yaml": "boundary: [[0, 0], [100, 0], [100, 100], [0, 100]]\n",
    "unknown_field.yaml": "boundary: [[0, 0], [100, 0], [100, 100], [0, 100]]\ncolour: red\n",
    "bad_profile.yaml": "wheel_diameter_cm: -3\n",
    "profile_text.yaml": "just words\n",
    "sonar.yaml": "kind: nxtnav-sonar-profile\nsonar: nxt\nparams:\n  noise_sd: 2.0\n  dropout_prob: 0.1\n",
    "bad_sonar.yaml": "params:\n  noise_sd: -1\n",
    "blocker": "a file where a folder is expected\n",
    "notamap.map": "this is not a Moving AI map\n",
    "notascen.scen": "version 1\ngarbage line\n",
}
BINARY = {"binary.yaml": bytes(range(256)) * 4}
FOLDERS = ("folder.yaml", "full")


@dataclass
class Case:
    """One command line (after ``nxtnav``), the exit code it must end with, and the environment variables
    it runs with (values are names in the scratch folder)."""

    group: str
    command: str
    expect: int = 2
    env: dict[str, str] = field(default_factory=dict)


def cases() -> list[Case]:
    """Every case, in the table's order."""
    c: list[Case] = []

    def add(group: str, expect: int, *commands: str, env: dict[str, str] | None = None) -> None:
        c.extend(Case(group, cmd, expect, env or {}) for cmd in commands)

    # the command line itself
    add("cli", 2, "bogus", "run --bogus", "plan --start", "maps show", "localise", "scan --pose",
        "bench world --poses", "run --seed abc", "plan --seed 1.5 -o p.png", "paper --trials many")
    # map files
    shows = [f"maps show {name} -o m.png" for name in (
        "missing.yaml", "nosuchmap", "syntax.yaml", "noboundary.yaml", "two.yaml", "bowtie.yaml", "flat.yaml",
        "text.yaml", "nan.yaml", "inf.yaml", "bool.yaml", "point3.yaml", "far.yaml", "bigint.yaml",
        "obstacle_out.yaml", "obstacles_overlap.yaml", "start_out.yaml", "target_wall.yaml", "empty.yaml",
        "list.yaml", "scalar.yaml", "binary.yaml", "folder.yaml", "unknown_field.yaml")]
    add("maps", 2, *shows)
    add("maps", 2, "maps show map1 --radius -5 -o m.png", "maps show map1 --radius -inf -o m.png",
        "maps show map1 --radius nan -o m.png", "maps show map1 --radius inf -o m.png",
        "maps show map1 -o full", "maps show map1 -o blocker/m.png", "maps show map1 -o /proc/m.png",
        "maps list --bogus")
    # plan
    p = "plan --exec-repeats 0 -o p.png"
    add("plan", 2, *(f"{p} --start {v}" for v in ("a,b", "1", "1,2,3,4", "nan,5", "inf,5", "1e300,5", "3,3",
                                                   "500,500", "60.5,50", "''")))
    add("plan", 2, *(f"{p} --goal {v}" for v in ("x", "3,3", "-1e7,0", "nan,nan")))
    add("plan", 2, f"{p} --planner nope", f"{p} --planner ompl:Nope", f"{p} --planner ''",
        f"{p} --time-limit 0", f"{p} --time-limit -1", f"{p} --time-limit nan", f"{p} --time-limit inf",
        f"{p} --time-limit abc", f"{p} --radius -1", f"{p} --radius -0.5", f"{p} --radius nan", f"{p} --radius 1000",
        f"{p} --seed -1", "plan --exec-repeats -1 -o p.png", "plan --exec-repeats 100000000 -o p.png",
        f"{p} --noise-model gaussian", f"{p} --motion-noise -1", f"{p} --turn-noise nan", "plan",
        "plan -o full", "plan -o blocker/p.png", f"{p} --json blocker/p.json", f"{p} --json full",
        f"{p} --map nopreset.yaml", f"{p} --map target_wall.yaml --start 5,5")
    add("plan", 1, f"{p} --map split.yaml", f"{p} --map split.yaml --planner rrtstar",
        f"{p} --map split.yaml --planner prm", f"{p} --map split.yaml --planner astar")
    # run
    add("run", 2, "run --map missing.yaml", "run --map syntax.yaml", "run --start 500,500", "run --start 3,3,0",
        "run --start 1,2,3,4", "run --start 30,30 --random-start", "run --target 3,50", "run --target 900,900",
        "run --target a,b", "run --planner nope", "run --localiser nope", "run --robot laser", "run --sonar radar",
        "run --noise-model x", "run --noise 1,2", "run --noise -1,0,0", "run --noise a,b,c", "run --noise nan,0,0",
        "run --seed -1", "run --json blocker/m.json", "run --plot full", "run --animate blocker/m.gif",
        "run --nxt-backend pigeon", "run --robot nxt --nxt-backend socket --server-port 70000",
        "run --robot nxt --nxt-backend socket --server-port 0", "run --robot nxt --start 1,1",
        "run --robot nxt --nxt-backend socket --server-port 1",
        "run --robot nxt --nxt-backend socket --server-port 1 --profile missing.yaml",
        "run --map nopreset.yaml", "run --map huge.yaml")
    add("run", 1, "run --map split.yaml")
    # paper
    add("paper", 2, "paper --trials 0", "paper --trials -1", "paper --trials 10000000", "paper --workers 0",
        "paper --workers 1000", "paper --maps nomap", "paper --maps ''", "paper --maps ,,", "paper --stack bad",
        "paper --stack nope/paper-pf", "paper --stack min-turn/nope", "paper --noise-model x", "paper --sonar x",
        "paper --seed -1", "paper --json blocker/t.json", "paper --markdown full", "paper --maps syntax.yaml")
    # localise
    lo = "localise --pose 20,20,0"
    add("localise", 2, "localise --pose 1,2", "localise --pose a,b,c", "localise --pose 500,500,0",
        "localise --pose 3,3,0", "localise --pose nan,1,0", f"{lo} --localiser nope",
        f"{lo} --localiser paper-pf,ekf", f"{lo} --sonar radar", f"{lo} --sensor-noise -1",
        f"{lo} --sensor-noise nan", f"{lo} --noise-model x", f"{lo} --tracker-prior x",
        f"{lo} --scan-processing x", f"{lo} --lobe x", f"{lo} --seed -1", f"{lo} --set n_particles",
        f"{lo} --set =3", f"{lo} --set nope=1", f"{lo} --set n_particles=abc", f"{lo} --set n_particles=100.5",
        f"{lo} --set n_particles=5", f"{lo} --set n_particles=true", f"{lo} --set ekf.n_particles=100",
        f"{lo} --set sensor.sensor_sigma_cm=.nan", f"{lo} -o full", f"{lo} -o blocker/l.png",
        f"{lo} --json blocker/l.json", "localise --map huge.yaml --pose 50,50,0", "localise --map nomap --pose 1,1,0")
    add("localise", 0, lo, "localise --map sym.yaml --pose 20,15,30")
    # scan
    sc = "scan --pose 20,20,0"
    add("scan", 2, "scan --pose 1,1", "scan --pose 500,1,0", "scan --pose x,y,z", f"{sc} --sonar radar",
        f"{sc} --sensor-noise -1", f"{sc} --sensor-noise inf", f"{sc} --seed -1", f"{sc} -o full",
        f"{sc} --json blocker/s.json", "scan --map nomap --pose 1,1,0", f"{sc} --angles 0:0:72",
        f"{sc} --angles 0:5:0", f"{sc} --angles 0:5:2.5", f"{sc} --angles 0:5", f"{sc} --angles a:b:c",
        f"{sc} --angles 0:5:1e12", f"{sc} --direction up")
    add("scan", 0, sc, f"{sc} --angles 0:5:72 --direction cw", f"{sc} --angles 180:1:1", f"{sc} --sonar laser")
    # import
    add("import", 2, "import", "import sweeps", "import sweeps nowhere -o r.jsonl", "import sweeps full -o r.jsonl",
        "import sweeps . -o r.jsonl", "import sweeps full --map nomap -o r.jsonl", "import bag x -o r.jsonl")
    # bench world
    add("bench world", 2, "bench world --poses 0", "bench world --poses -1", "bench world --poses 100000000",
        "bench world --poses abc", "bench world --repeats -1", "bench world --repeats 0", "bench world --segments 0",
        "bench world --seed -1", "bench world --map nomap", "bench world --map syntax.yaml")
    # bench planners
    bp = "bench planners --maps map1 --planners min-turn --runs 1 --out bp"
    add("bench planners", 2, "bench planners --runs 0 --out bp", "bench planners --runs -1 --out bp",
        "bench planners --time-limit 0 --out bp", "bench planners --time-limit nan --out bp",
        "bench planners --planners nope --out bp", "bench planners --planners '' --out bp",
        "bench planners --planners ompl:Nope --out bp", "bench planners --maps nomap --out bp",
        "bench planners --queries sometimes --out bp", "bench planners --out blocker",
        "bench planners --out full", "bench planners --workers 0 --out bp",
        "bench planners --exec-repeats -1 --out bp", "bench planners --radius -1 --out bp",
        "bench planners --noise-model x --out bp", "bench planners --seed -1 --out bp",
        "bench planners --motion-noise -1 --out bp", "bench planners", f"{bp} --turn-noise inf",
        f"{bp} --simplify smooth", f"{bp} --simplify ''", f"{bp} --budgets ''", f"{bp} --budgets 0.1,-1",
        f"{bp} --budgets 0.1,0", f"{bp} --budgets 0.1,0.1", f"{bp} --budgets fast", f"{bp} --budgets 0.1,inf",
        f"{bp} --budgets 0.1 --time-limit 1", f"{bp} --progress-interval 0", f"{bp} --progress-interval -1")
    # bench localisers
    bl = "bench localisers --maps map1 --localisers paper-pf --trials 1 --out bl"
    add("bench localisers", 2, f"{bl} --trials 0", f"{bl} --localisers nope", "bench localisers --maps nomap --out bl",
        f"{bl} --scenario nope", f"{bl} --sonar radar", f"{bl} --sensor-noise -1", f"{bl} --tracker-prior x",
        f"{bl} --tracking-steps 0", f"{bl} --recovery-rounds 0", f"{bl} --scan-processing x",
        f"{bl} --exploration wander", f"{bl} --lobe x",
        f"{bl} --seed -1", f"{bl} --set paper-pf.n_particles=abc", f"{bl} --set paper-pf.n_particles=5",
        f"{bl} --set nope.x=1", f"{bl} --set bogus=1", "bench localisers --maps map1 --out blocker",
        "bench localisers --maps map1 --out full", f"{bl} --workers 0", "bench localisers")
    # the virtual brick (every case must fail: a good one would serve forever)
    add("brick serve", 2, "brick serve --port 70000", "brick serve --port -1", "brick serve --time-factor 0",
        "brick serve --time-factor -1", "brick serve --time-factor nan", "brick serve --max-step 0",
        "brick serve --sonar radar", "brick serve --sensor-noise -1", "brick serve --seed -1",
        "brick serve --wheel-diameter 0", "brick serve --track-width -1", "brick serve --radius 0",
        "brick serve --wheel-slip -0.1", "brick serve --wheel-slip 0.9", "brick serve --brake-decel 0",
        "brick serve --pose 500,500,0", "brick serve --pose a,b,c", "brick serve --map nomap",
        "brick serve --map nopreset.yaml", "brick serve --log blocker/t.jsonl", "brick serve --host 999.1.1.1 --port 0",
        "brick serve --fault meteor:1:2", "brick serve --fault drop-link:x:3", "brick serve --fault stall:5",
        "brick serve --fault drop-link:1:0", "brick serve --fault sonar-garbage:2",
        "brick serve --fault motor-slip:1:-1", "brick serve --fault sonar-stuck:1:2:3",
        "brick serve --reassembly-window 0", "brick serve --reassembly-window nan")
    add("bench faults", 2, "bench faults --missions 0", "bench faults --faults meteor", "bench faults --maps nomap",
        "bench faults --maps nopreset.yaml", "bench faults --workers 0", "bench faults --json blocker/f.json",
        "bench faults --reconnect-timeout -1", "bench faults --reply-timeout 0", "bench faults --seed -1")
    add("run (nxt link)", 2, "run --reconnect-timeout -1", "run --reconnect-timeout nan", "run --reply-timeout 0")
    # a real NXT, with nothing at the other end
    add("nxt", 2, "nxt check --nxt-backend pigeon", "nxt check --nxt-backend socket --server-port 0",
        "nxt check --nxt-backend socket --server-port 70000", "nxt check --nxt-backend socket --server-port 1",
        "nxt check --nxt-backend socket --server-port 1 --readings 0",
        "nxt check --nxt-backend socket --server-port 1 --profile missing.yaml",
        "nxt check --nxt-backend socket --server-port 1 --profile bad_profile.yaml",
        "nxt check --nxt-backend socket --server-port 1 --profile profile_text.yaml",
        "nxt calibrate --nxt-backend socket --server-port 1 --distance 0",
        "nxt calibrate --nxt-backend socket --server-port 1 --distance nan",
        "nxt calibrate --nxt-backend socket --server-port 1 --angle -5",
        "nxt calibrate --nxt-backend socket --server-port -1", "nxt calibrate --nxt-backend socket --server-port 1")
    # sonar profiles (nxtnav sonar fit writes them; --sonar-profile reads them) and the sonar commands
    sp = "--sonar nxt --sonar-profile"
    add("sonar profile", 2, f"{sc} {sp} missing.yaml", f"{sc} {sp} binary.yaml", f"{sc} {sp} syntax.yaml",
        f"{sc} {sp} profile_text.yaml", f"{sc} {sp} bad_profile.yaml", f"{sc} {sp} folder.yaml",
        f"{sc} {sp} bad_sonar.yaml", f"{sc} --sonar ideal --sonar-profile sonar.yaml",
        f"localise --pose 20,20,0 {sp} bad_sonar.yaml", f"run {sp} bad_sonar.yaml",
        f"paper --trials 1 {sp} bad_sonar.yaml", f"{bl} {sp} bad_sonar.yaml", f"brick serve {sp} bad_sonar.yaml",
        "sonar fit nowhere -o p.yaml", "sonar fit full -o p.yaml", "sonar fit . -o full",
        "sonar fit . -o p.yaml --widths 0", "sonar fit . -o p.yaml --criticals 91,x", "sonar score nowhere",
        "sonar score . --sonar-profile bad_sonar.yaml", "sonar score . --baseline nope", "sonar loo nowhere",
        "sonar loo . --workers 0")
    add("sonar profile", 0, f"{sc} {sp} sonar.yaml")
    # map import and scenario files
    add("maps import", 2, "maps import missing.map -o out.yaml", "maps import notamap.map -o out.yaml",
        "maps import syntax.yaml -o out.yaml", "maps import notamap.map -o blocker/out.yaml")
    add("bench scen", 2, "bench scen missing.scen --kind octile", "bench scen notascen.scen --kind octile",
        "bench scen notascen.scen --kind sideways", "bench scen notascen.scen --kind octile --seed -1")
    # the environment
    add("environment", 0, "run", env={"NXTNAV_CACHE_DIR": "blocker"})
    add("environment", 0, "localise --pose 20,20,0", env={"NXTNAV_CACHE_DIR": "badcache"})
    add("environment", 2, "run --map odd", env={"NXTNAV_MAPS": "blocker"})
    return c


def prepare(folder: Path, exe: str) -> None:
    """Write the files the cases name into `folder`; `exe` (the console script) builds a range-table
    cache there whose files then get another grid's table."""
    for name, text in FILES.items():
        (folder / name).write_text(text)
    for name, data in BINARY.items():
        (folder / name).write_bytes(data)
    for name in FOLDERS:
        (folder / name).mkdir()
    (folder / "full" / "something").write_text("x")
    (folder / "sym.yaml").write_text("name: twins\nboundary: [[0, 0], [80, 0], [80, 20], [120, 20], [120, 60], "
                                     "[40, 60], [40, 40], [0, 40]]\n")
    # a range-table cache whose files hold another grid's table
    import numpy as np

    cache = folder / "badcache"
    env = {**os.environ, "NXTNAV_CACHE_DIR": str(cache)}
    subprocess.run([exe, "localise", "--pose", "20,20,0"], cwd=folder, env=env, capture_output=True, timeout=300)
    for f in cache.glob("*.npy"):
        np.save(f, np.zeros((7, 5), dtype=np.float32))
