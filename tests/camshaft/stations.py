"""Small multi-cam machines for the camshaft tests (issue 38), and each station alone.

Three stations on one shaft at 300 rpm:

* ``feed`` drives mass A1 (``drives``), a spring to A2, A2 on a preloaded return spring;
* ``clamp`` pushes mass B through a compliant roller contact against a preloaded spring
  (force-closed: it can leave the cam);
* ``press`` drives P1, a spring to the ram P2, which strikes a compliant stop after a gap
  (an impact station).

:func:`multi_toml` writes them on one camshaft with phases; :func:`alone_toml` writes one
station as a one-cam file with the same phase as its start angle — the reference of a
rigid shaft at constant speed (spec §9).
"""

from __future__ import annotations

SPEED = "300 rpm"

PROGRAMS = {
    "feed": '''segments = [
  { motion = "rise", law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
  { motion = "fall", law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
]''',
    "clamp": '''segments = [
  { motion = "rise", law = "poly345", duration = "60 deg", lift = "5 mm" },
  { motion = "dwell", duration = "120 deg" },
  { motion = "fall", law = "poly345", duration = "60 deg", lift = "5 mm" },
  { motion = "dwell", duration = "120 deg" },
]''',
    "press": '''segments = [
  { motion = "rise", law = "modified-sine", duration = "80 deg", lift = "12 mm" },
  { motion = "dwell", duration = "100 deg" },
  { motion = "fall", law = "modified-trapezoid", duration = "80 deg", lift = "12 mm" },
  { motion = "dwell", duration = "100 deg" },
]''',
}

DRIVES = {"feed": "A1", "clamp": None, "press": "P1"}

MASSES = {
    "feed": [("A1", "1.0 kg"), ("A2", "0.5 kg")],
    "clamp": [("B", "0.4 kg")],
    "press": [("P1", "0.8 kg"), ("P2", "0.3 kg")],
}


def _elements(station: str, cam_node: str) -> str:
    if station == "feed":
        return '''
[[element]]
name = "kA"
type = "spring"
between = ["A1", "A2"]
stiffness = "1e5 N/m"
damping_ratio = 0.05

[[element]]
name = "gA"
type = "spring"
between = ["ground", "A2"]
stiffness = "2e3 N/m"
preload = "20 N"
damping_ratio = 0.05
'''
    if station == "clamp":
        return f'''
[[element]]
name = "rollB"
type = "contact"
between = ["{cam_node}", "B"]
stiffness = "1e6 N/m"
damping_ratio = 0.1

[[element]]
name = "gB"
type = "spring"
between = ["ground", "B"]
stiffness = "3e3 N/m"
preload = "30 N"
damping_ratio = 0.05
'''
    return '''
[[element]]
name = "kP"
type = "spring"
between = ["P1", "P2"]
stiffness = "4e5 N/m"
damping_ratio = 0.05

[[element]]
name = "stopP"
type = "contact"
between = ["ground", "P2"]
gap = "9 mm"
stiffness = "5e6 N/m"
damping_ratio = 0.1
transducer = true
'''


def _masses(station: str) -> str:
    return "".join(f'\n[[mass]]\nname = "{n}"\nmass = "{m}"\n' for n, m in MASSES[station])


SIM = '''
[simulation]
cycles = 1
warmup_cycles = 1
sample_rate = "20 kHz"
'''


def multi_toml(stations=("feed", "clamp", "press"), phases=None, camshaft: str = "", extra: str = "",
               sim: str = SIM) -> str:
    """The stations on one shaft: ``[[cam]]`` tables named as the stations, with ``phases`` [deg]."""
    phases = phases or {"feed": 0.0, "clamp": 120.0, "press": 240.0}
    out = ['schema = 1\n\n[machine]\nname = "three stations"\n']
    out.append(f'\n[camshaft]\nspeed = "{SPEED}"\n{camshaft}\n')
    for st in stations:
        drives = f'drives = "{DRIVES[st]}"\n' if DRIVES[st] else ""
        out.append(f'\n[[cam]]\nname = "{st}"\nphase = "{phases[st]} deg"\n{drives}{PROGRAMS[st]}\n')
    for st in stations:
        out.append(_masses(st))
    for st in stations:
        out.append(_elements(st, st))
    out.append(extra)
    out.append(sim)
    return "".join(out)


def alone_toml(station: str, phase_deg: float, sim: str = SIM) -> str:
    """One station as a one-cam file, its phase as the start angle."""
    drives = f'drives = "{DRIVES[station]}"\n' if DRIVES[station] else ""
    out = [f'schema = 1\n\n[machine]\nname = "{station} alone"\n',
           f'\n[cam]\nspeed = "{SPEED}"\nstart_angle = "{phase_deg} deg"\n{drives}{PROGRAMS[station]}\n',
           _masses(station), _elements(station, "cam"), sim]
    return "".join(out)
