"""Every input of issue 62's list, run as a user runs it: one row per input with the command, its exit code, the last
line it printed (stderr, else stdout; for a run that prints a summary, its verdict lines: a failed criterion,
a note, an error), wall seconds and the child's max RSS.

    python benchmarks/issue62_inputs.py [--root REPO] [--only SUBSTRING] [--timeout 600] [--json FILE]

``--root``: the checkout whose ``wbc`` runs (``python -m wbc`` with ``PYTHONPATH=ROOT``; default: this script's
repository), so the same list runs on an old commit's worktree ("before") and on a branch ("after"). Each input
runs in a fresh temporary folder (its cwd); a file left there (``MUJOCO_LOG.TXT``, ``.partial``) is named on the
row. The hostile robot files are written into that folder from the catalog's humanoid15 and talos files, one edit
each, as the issue's cases name them. Signal cases send the signal 3 s after the command's SIGTERM handler is
installed (read from /proc/PID/status). Timing: wall seconds beside the load average printed on the first line.
Linux only (/proc, wait4).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def _chain(n_links: int, moving: bool = True) -> str:
    """A URDF of ``n_links`` links in a chain."""
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>'
                '</inertial>')
    kind = ('type="revolute"><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/'
            if moving else 'type="fixed"')
    parts = ['<?xml version="1.0"?>\n<robot name="chain">', f'<link name="l0">{inertial}</link>']
    for i in range(1, n_links):
        parts.append(f'<link name="l{i}">{inertial}</link><joint name="j{i}" {kind}><parent link="l{i - 1}"/>'
                     f'<child link="l{i}"/><origin xyz="0 0 0.01"/></joint>')
    return "\n".join(parts + ["</robot>\n"])


def _big_urdf(path: Path, megabytes: int = 200) -> None:
    """A URDF of about ``megabytes`` MB of repeated links (written, not sparse)."""
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>'
                '</inertial>')
    with open(path, "w") as f:
        f.write('<?xml version="1.0"?>\n<robot name="big">\n<link name="l0">' + inertial + "</link>\n")
        i, size = 1, 0
        while size < megabytes * 1_000_000:
            s = (f'<link name="l{i}">{inertial}</link><joint name="j{i}" type="fixed"><parent link="l{i - 1}"/>'
                 f'<child link="l{i}"/><origin xyz="0 0 0.01"/></joint>\n')
            f.write(s)
            size += len(s)
            i += 1
        f.write("</robot>\n")


def _edited(text: str, edit) -> str:
    """``text`` with its first ``edit[0]`` replaced by ``edit[1]`` (which must be there); unchanged when None."""
    if edit is None:
        return text
    assert edit[0] in text, edit
    return text.replace(*edit, 1)


class Files:
    """Writes the hostile robot files of one case into ``d`` (the case's cwd); returns the path to give."""

    def __init__(self, d: Path, root: Path):
        self.d, self.robots = d, root / "robots"

    def h15(self, urdf_edit=None, toml_edit=None, extra: str = "") -> str:
        """humanoid15 with one edit of its URDF text and/or robot file."""
        shutil.copy(self.robots / "humanoid15.srdf", self.d / "humanoid15.srdf")
        (self.d / "humanoid15.urdf").write_text(_edited((self.robots / "humanoid15.urdf").read_text(), urdf_edit))
        (self.d / "robot.toml").write_text(_edited((self.robots / "humanoid15.toml").read_text(), toml_edit) + extra)
        return str(self.d / "robot.toml")

    def talos(self, toml_edit=None, extra: str = "") -> str:
        (self.d / "talos.toml").write_text(_edited((self.robots / "talos.toml").read_text(), toml_edit) + extra)
        return str(self.d / "talos.toml")

    def raw(self, name: str, data: bytes | str) -> str:
        p = self.d / name
        p.write_bytes(data if isinstance(data, bytes) else data.encode())
        return str(p)

    def chain(self, urdf_text: str) -> str:
        (self.d / "chain.urdf").write_text(urdf_text)
        return self.raw("chain.toml", 'urdf = "chain.urdf"\nleft_sole = "l1"\nright_sole = "l2"\ntorso = "l0"\n')

    def big(self) -> str:
        _big_urdf(self.d / "chain.urdf")
        return self.raw("chain.toml", 'urdf = "chain.urdf"\nleft_sole = "l1"\nright_sole = "l2"\ntorso = "l0"\n')


MOVED = '\n[[frames]]\nname = "moved"\nparent = "left_sole"\nxyz = [{}, {}, 0.0]\n'
XML_BOMB = ('<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
            + "".join(f'<!ENTITY lol{i} "{("&lol" + (str(i - 1) if i > 1 else "") + ";") * 10}">' for i in range(1, 10))
            + ']>\n<robot name="x"><link name="&lol9;"/></robot>\n')
XXE = ('<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY xxe SYSTEM "file:///etc/passwd">]>\n'
       '<robot name="x"><link name="&xxe;"/></robot>\n')


def cases():
    """(name, argv builder (Files → argv after ``wbc``), signal or None). The list of issue 62, in its order."""
    c = []
    add = lambda name, build, sig=None: c.append((name, build, sig))  # noqa: E731
    # Exit codes a script cannot trust
    add("walk stairs tread 0.1 m", lambda f: ["walk", "--terrain", "stairs:0.5:0.1:3"])
    add("sim walk stairs tread 0.1 m", lambda f: ["sim", "walk", "--terrain", "stairs:0.5:0.1:3"])
    add("walk stairs updown, 8 steps", lambda f: ["walk", "--terrain", "stairs:0.1:0.3:3:updown"])
    add("sim walk stairs updown, 8 steps", lambda f: ["sim", "walk", "--terrain", "stairs:0.1:0.3:3:updown"])
    add("sim push --force 1e9", lambda f: ["sim", "push", "--force", "1e9"])
    add("sim push --height 100", lambda f: ["sim", "push", "--height", "100"])
    add("sim push --mass-error -10", lambda f: ["sim", "push", "--mass-error", "-10"])
    add("campaign force 1e9", lambda f: ["campaign", "run", "--kind", "push", "--trials", "2", "--results", "c",
                                         "--no-plots", "--no-progress", "--set", "factors.force=1e9"])
    add("campaign force 5000 N for 2 s", lambda f: ["campaign", "run", "--kind", "push", "--trials", "2",
                                                    "--results", "c", "--no-plots", "--no-progress", "--set",
                                                    "factors.force=5000", "--set", "factors.push_duration=2"])
    # Messages
    add("walk --step-length nan", lambda f: ["walk", "--step-length", "nan"])
    add("walk --vx nan", lambda f: ["walk", "--vx", "nan"])
    add("walk --wz nan", lambda f: ["walk", "--wz", "nan"])
    add("walk --step-length -0.1", lambda f: ["walk", "--step-length", "-0.1"])
    add("plot /etc/passwd", lambda f: ["plot", "/etc/passwd"])
    add("wrong sole frame rgbd (talos)", lambda f: ["robot", "check", f.talos(("left_sole_link", "rgbd"))])
    add("--help (last line)", lambda f: ["--help"])
    add("sim --help (scenarios)", lambda f: ["sim", "--help"])
    add("examples/custom_gait.py --help", lambda f: ["EXAMPLE", "custom_gait.py", "--help"])
    # Hostile robot files
    add("robot file: malformed TOML", lambda f: ["robot", "check", f.raw("r.toml", 'urdf = "x.urdf"\nname = [1,\n')])
    add("robot file: missing key", lambda f: ["robot", "check", f.h15(toml_edit=('left_sole = "left_sole"\n', ""))])
    add("robot file: path traversal", lambda f: ["robot", "check", f.h15(
        toml_edit=('urdf = "humanoid15.urdf"', 'urdf = "../../../../etc/passwd"'))])
    add("robot file: /etc/passwd", lambda f: ["robot", "check", "/etc/passwd"])
    add("robot file: a directory", lambda f: ["robot", "check", str(f.d)])
    add("robot file: a FIFO", lambda f: (os.mkfifo(f.d / "fifo.toml"), ["robot", "check", str(f.d / "fifo.toml")])[1])
    add("robot file: /dev/zero", lambda f: ["robot", "check", "/dev/zero"])
    add("URDF: billion laughs", lambda f: ["robot", "check", (f.raw("chain.urdf", XML_BOMB), f.raw(
        "chain.toml", 'urdf = "chain.urdf"\nleft_sole = "l1"\nright_sole = "l2"\ntorso = "l0"\n'))[1]])
    add("URDF: XXE", lambda f: ["robot", "check", (f.raw("chain.urdf", XXE), f.raw(
        "chain.toml", 'urdf = "chain.urdf"\nleft_sole = "l1"\nright_sole = "l2"\ntorso = "l0"\n'))[1]])
    add("robot file: non-UTF-8 bytes", lambda f: ["robot", "check", f.raw("r.toml", b'urdf = "x.urdf"\nname = "caf\xe9"\n')])
    add("robot file: nested array", lambda f: ["robot", "check", f.raw("r.toml", "urdf = " + "[" * 100_000
                                                                        + "]" * 100_000 + "\n")])
    add("robot file: [[frames]] reuses a frame name", lambda f: ["robot", "check", f.h15(
        extra='\n[[frames]]\nname = "torso"\nparent = "pelvis"\n')])
    add("URDF: 200 MB of repeated links", lambda f: ["robot", "check", f.big()])
    add("URDF: 200 MB, walk SIGTERM", lambda f: ["walk", "--robot", f.big()], signal.SIGTERM)
    for where, x, y in [("0.15 m ahead", 0.15, 0.0), ("0.3 m to the side", 0.0, 0.3)]:
        for cmd in (["robot", "check"], ["walk", "--robot"], ["sim", "walk", "--robot"]):
            add(f"sole frame {where}: {' '.join(cmd)}", lambda f, x=x, y=y, cmd=cmd: [*cmd, f.h15(
                toml_edit=('left_sole = "left_sole"', 'left_sole = "moved"'), extra=MOVED.format(x, y))])
    add("URDF: mass -3 kg", lambda f: ["robot", "check", f.h15(urdf_edit=('<mass value="0.3"/>', '<mass value="-3"/>'))])
    for attr in ("velocity", "effort"):
        add(f"URDF: negative {attr} limit", lambda f, a=attr: ["robot", "check", f.h15(urdf_edit=(
            'velocity="10" effort="150"', 'velocity="10" effort="150"'.replace(f'{a}="', f'{a}="-')))])
    add("URDF: axis 0 0 0", lambda f: ["robot", "check", f.h15(urdf_edit=(
        '<axis xyz="0 1 0"/>\n    <limit lower="0" upper="2.4"', '<axis xyz="0 0 0"/>\n    <limit lower="0" upper="2.4"'))])
    add("URDF: ixx 1e400", lambda f: ["robot", "check", f.h15(urdf_edit=('ixx="0.02535"', 'ixx="1e400"'))])
    add("robot file: [gait] step_length 0.9", lambda f: ["robot", "check", f.h15(
        toml_edit=("step_length = 0.10", "step_length = 0.9"))])
    add("robot file: [gait] t_ss 0.1", lambda f: ["robot", "check", f.h15(
        toml_edit=("t_ss = 0.7\nt_ds = 0.25", "t_ss = 0.1\nt_ds = 0.05"))])
    add("URDF: 501 links", lambda f: ["robot", "check", f.chain(_chain(501, moving=False))])
    # Processes and signals
    add("walk SIGTERM", lambda f: ["walk", "--robot", "humanoid15", "--steps", "400", "--quiet", "--log", "run.npz"],
        signal.SIGTERM)
    add("walk SIGINT", lambda f: ["walk", "--robot", "humanoid15", "--steps", "400", "--quiet", "--log", "run.npz"],
        signal.SIGINT)
    add("ros2 node SIGTERM", lambda f: ["ros2", "node", "--robot", "humanoid15"], signal.SIGTERM)
    return c


def catches(pid: int, sig: int) -> bool:
    """Whether process ``pid`` has a handler for ``sig`` (bit sig − 1 of SigCgt in /proc/PID/status)."""
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    mask = int(next(line.split()[1] for line in text.splitlines() if line.startswith("SigCgt:")), 16)
    return bool(mask >> (sig - 1) & 1)


def run(root: Path, name: str, build, sig, timeout: float) -> dict:
    """Run one case in a fresh folder; the row."""
    with tempfile.TemporaryDirectory(prefix="i62-") as tmp:
        d = Path(tmp)
        argv = build(Files(d, root))
        if argv[0] == "EXAMPLE":
            cmd = [sys.executable, str(root / "examples" / argv[1]), *argv[2:]]
        else:
            cmd = [sys.executable, "-m", "wbc", *argv]
        env = {**os.environ, "PYTHONPATH": str(root), "PYTHONUNBUFFERED": "1"}
        before = set(os.listdir(d))
        with open(d / ".out", "w") as out, open(d / ".err", "w") as err:
            t0 = time.monotonic()
            proc = subprocess.Popen(cmd, stdout=out, stderr=err, stdin=subprocess.DEVNULL, cwd=d, env=env,
                                    start_new_session=True,  # SIGINT as a terminal leaves it (a background
                                    preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # job ignores it)
            sent, note = False, ""
            while True:
                pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
                if pid:
                    break
                now = time.monotonic() - t0
                if sig is not None and not sent and catches(proc.pid, signal.SIGTERM):
                    time.sleep(3.0)
                    os.kill(proc.pid, sig)
                    sent, t_sig = True, time.monotonic()
                if now > timeout or (sent and time.monotonic() - t_sig > 5.0 and not note):
                    note = (f"still running {timeout:.0f} s after start: killed" if now > timeout
                            else f"still running 5 s after {signal.Signals(sig).name}: killed")
                    os.killpg(proc.pid, signal.SIGKILL)
                time.sleep(0.02)
            seconds = time.monotonic() - t0
        code = os.waitstatus_to_exitcode(status)
        proc.returncode = code
        text_err = (d / ".err").read_text(errors="replace").strip()
        text_out = (d / ".out").read_text(errors="replace").strip()
        last = (text_err or text_out).splitlines()[-1] if (text_err or text_out) else ""
        verdicts = [ln.strip() for ln in (text_err + "\n" + text_out).splitlines()
                    if re.match(r"\s*(failed|passed|note|warning|error|wbc[\w -]*: (error|note|warning))\b", ln)]
        if verdicts:  # a run's verdict lines (failed criterion, note, error) rather than the summary's last row
            last = " / ".join(dict.fromkeys(verdicts))
        left = sorted(p.name for p in d.rglob("*") if p.name not in before and p.name not in (".out", ".err")
                      and (p.name == "MUJOCO_LOG.TXT" or ".partial" in p.name))
        return {"name": name, "command": "wbc " + " ".join(a if len(a) < 60 else a[:57] + "..." for a in argv),
                "signal": signal.Signals(sig).name if sig else "", "exit": code, "last_line": last,
                "stderr_lines": len(text_err.splitlines()), "traceback": "Traceback" in text_err,
                "seconds": round(seconds, 1), "max_rss_mb": round(usage.ru_maxrss / 1024, 1), "left": left,
                "note": note}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--root", type=Path, default=HERE)
    p.add_argument("--only", default="")
    p.add_argument("--timeout", type=float, default=600.0)
    p.add_argument("--json", type=Path)
    a = p.parse_args()
    root = a.root.resolve()
    commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    print(f"# root {root} ({commit}), load {Path('/proc/loadavg').read_text().split()[:3]}", flush=True)
    rows = []
    for name, build, sig in cases():
        if a.only and not re.search(a.only, name):
            continue
        r = run(root, name, build, sig, a.timeout)
        rows.append(r)
        sig_s = f" [{r['signal']}]" if r["signal"] else ""
        extra = (f" stderr {r['stderr_lines']} lines" if r["stderr_lines"] > 1 else "") + \
            (" TRACEBACK" if r["traceback"] else "") + (f" left {r['left']}" if r["left"] else "") + \
            (f" ({r['note']})" if r["note"] else "")
        print(f"{r['name']}{sig_s} | exit {r['exit']} | {r['seconds']} s | {r['max_rss_mb']} MB |{extra} "
              f"{r['last_line'][:400]}", flush=True)
    print(f"# load {Path('/proc/loadavg').read_text().split()[:3]}")
    if a.json:
        a.json.write_text(json.dumps({"root": str(root), "commit": commit, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
