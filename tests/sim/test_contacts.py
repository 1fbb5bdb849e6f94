"""ContactPartners agrees with a loop over data.contact."""

from __future__ import annotations

import mujoco

from trossen_arm_mujoco.sim.contacts import ContactPartners

XML = """
<mujoco>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.2"><freejoint/><geom name="a" size="0.05"/></body>
    <body pos="0.06 0 0.4"><freejoint/><geom name="b" size="0.05"/></body>
    <body pos="0.5 0 0.2"><freejoint/><geom name="c" type="box" size="0.05 0.05 0.05"/></body>
  </worldbody>
</mujoco>
"""


def _loop(data, geoms):
    out = set()
    for i in range(data.ncon):
        g1, g2 = int(data.contact.geom1[i]), int(data.contact.geom2[i])
        if g1 in geoms:
            out.add(g2)
        if g2 in geoms:
            out.add(g1)
    return out


def test_partners_match_a_loop_over_the_contacts():
    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    ids = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in "abc"}
    ids["floor"] = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    queries = [[ids["a"]], [ids["floor"]], [ids["a"], ids["b"]], [ids["c"]]]
    partners = [ContactPartners(model, q) for q in queries]
    assert all(p(data) == set() for p in partners)  # no contact yet
    seen = set()
    for _ in range(400):
        mujoco.mj_step(model, data)
        for query, p in zip(queries, partners):
            got = p(data)
            assert got == _loop(data, set(query))
            seen |= got
    assert {ids["floor"], ids["a"], ids["b"], ids["c"]} <= seen
