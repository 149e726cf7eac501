"""Write a left/right mirror-symmetric Talos for mirror-pair experiments (record 40): ``python
benchmarks/talos_mirror_model.py OUT_DIR`` writes OUT_DIR/talos_sym.urdf (every right-side ``<inertial>`` = the mirrored
left one: CoM y and rpy roll/yaw negated, Ixy and Iyz negated; centre links' CoM y = 0 and Ixy = Iyz = 0),
talos_sym.srdf (half_sitting with each right joint = the mirrored left value) and talos_sym.toml (robots/talos.toml
with those files), for ``--robot OUT_DIR/talos_sym.toml``. Meshes, limits and joints are example-robot-data's."""
import copy
import os
import re
import sys
import xml.etree.ElementTree as ET

import numpy as np

import wbc

r = wbc.load_robot("talos")
OUT = sys.argv[1] if len(sys.argv) > 1 else "talos_sym"
os.makedirs(OUT, exist_ok=True)
HERE = os.path.dirname(os.path.abspath(__file__))
def sw(n): return n.replace("left", "@").replace("right", "left").replace("@", "right")
tree = ET.parse(r.urdf_path); root = tree.getroot()
links = {l.get("name"): l for l in root.findall("link")}
changed = []
for name, link in links.items():
    ine = link.find("inertial")
    if ine is None: continue
    if "right" in name and sw(name) in links and links[sw(name)].find("inertial") is not None:
        src = copy.deepcopy(links[sw(name)].find("inertial"))
        o = src.find("origin")
        if o is None: o = ET.SubElement(src, "origin", xyz="0 0 0", rpy="0 0 0")
        xyz = [float(v) for v in o.get("xyz").split()]; rpy = [float(v) for v in o.get("rpy", "0 0 0").split()]
        o.set("xyz", f"{xyz[0]} {-xyz[1]} {xyz[2]}"); o.set("rpy", f"{-rpy[0]} {rpy[1]} {-rpy[2]}")
        i = src.find("inertia"); i.set("ixy", str(-float(i.get("ixy")))); i.set("iyz", str(-float(i.get("iyz"))))
        link.remove(ine); link.insert(0, src); changed.append(name)
    elif "left" not in name and "right" not in name:
        o = ine.find("origin")
        if o is None: o = ET.SubElement(ine, "origin", xyz="0 0 0", rpy="0 0 0")
        xyz = [float(v) for v in o.get("xyz").split()]
        rpy = [float(v) for v in o.get("rpy", "0 0 0").split()]
        assert abs(rpy[0]) < 1e-12 and abs(rpy[2]) < 1e-12, (name, rpy)
        o.set("xyz", f"{xyz[0]} 0.0 {xyz[2]}"); i = ine.find("inertia"); i.set("ixy", "0.0"); i.set("iyz", "0.0")
        changed.append(name)
tree.write(f"{OUT}/talos_sym.urdf")
# SRDF: mirrored half_sitting (right = s * left, centre joints with s = -1 at 0)
m = r.model; M = np.diag([1., -1., 1.]); ax = {"JointModelRX": [1,0,0], "JointModelRY": [0,1,0], "JointModelRZ": [0,0,1]}
def sign(n):
    a = np.array(ax[m.joints[m.getJointId(n)].shortname()], float); b = np.array(ax[m.joints[m.getJointId(sw(n))].shortname()], float)
    return float(np.dot(-M @ a, b))
s = open(r.srdf_path).read()
vals = dict(re.findall(r'<joint name="([^"]+)" value="([^"]+)"', s.split("half_sitting")[1].split("</group_state>")[0]))
fixed = []
for n, v in vals.items():
    if "right" in n and sw(n) in vals:
        new = sign(sw(n)) * float(vals[sw(n)])
        if abs(new - float(v)) > 0: fixed.append((n, v, new))
    elif "left" not in n and "right" not in n and n in m.names and m.joints[m.getJointId(n)].shortname() in ax and sign(n) < 0 and float(v) != 0.0:
        fixed.append((n, v, 0.0))
pre, rest = s.split('<group_state name="half_sitting"', 1); body, post = rest.split("</group_state>", 1)
for n, v, new in fixed:
    body = body.replace(f'<joint name="{n}" value="{v}"', f'<joint name="{n}" value="{new!r}"')
open(f"{OUT}/talos_sym.srdf", "w").write(pre + '<group_state name="half_sitting"' + body + "</group_state>" + post)
share = str(r.urdf_path).split("/example-robot-data/")[0]
toml = open(os.path.join(HERE, "..", "robots", "talos.toml")).read()
toml = toml.replace('urdf = "erd:talos_data/robots/talos_reduced.urdf"', f'name = "talos_sym"\nurdf = "{OUT}/talos_sym.urdf"\npackage_dirs = ["{share}"]')
toml = toml.replace('srdf = "erd:talos_data/srdf/talos.srdf"', f'srdf = "{OUT}/talos_sym.srdf"')
open(f"{OUT}/talos_sym.toml", "w").write(toml)
print("inertials changed:", len(changed), "; half_sitting entries mirrored:", fixed)
