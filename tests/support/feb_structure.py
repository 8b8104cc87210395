"""Checks a mesh.feb against the required structure of FEBio's febio_spec 4.0 with Python's XML
parser: sections in the specification's order, every reference (node sets, surfaces, element sets,
mapped parameters, load controllers, materials) resolved, element node counts of the element type,
node ids in range. Prints OK or the first violation (exit status 1). Usage: feb_structure.py FILE"""
import sys
import xml.etree.ElementTree as ET

ORDER = ["Module", "Globals", "Control", "Material", "Mesh", "MeshDomains", "MeshData", "Boundary", "Loads",
         "LoadData", "Output", "Step"]
NODES_PER = {"tet4": 4, "tet10": 10, "tri3": 3, "tri6": 6}


def ids(text):
    return [int(x) for x in text.split(",") if x.strip()]


def check(path):
    root = ET.parse(path).getroot()
    assert root.tag == "febio_spec", "root is <%s>, not <febio_spec>" % root.tag
    assert root.get("version") == "4.0", "febio_spec version %s, not 4.0" % root.get("version")
    tags = [c.tag for c in root]
    for t in tags:
        assert t in ORDER, "unknown section <%s>" % t
    assert tags == sorted(tags, key=ORDER.index), "sections out of order: %s" % tags
    for t in ["Module", "Control", "Material", "Mesh", "MeshDomains"]:
        assert t in tags, "required section <%s> missing" % t
    assert root.find("Module").get("type") == "solid", "Module type is not solid"
    control = root.find("Control")
    for t in ["analysis", "time_steps", "step_size"]:
        assert control.find(t) is not None, "Control/%s missing" % t
    mesh = root.find("Mesh")
    node_ids = {int(n.get("id")) for n in mesh.find("Nodes")}
    assert node_ids == set(range(1, len(node_ids) + 1)), "node ids are not 1..n"
    for n in mesh.find("Nodes"):
        assert len(n.text.split(",")) == 3, "node %s has not 3 coordinates" % n.get("id")
    parts = {}
    for el in mesh.findall("Elements"):
        k = NODES_PER[el.get("type")]
        for e in el:
            v = ids(e.text)
            assert len(v) == k, "element %s has %d nodes, %s needs %d" % (e.get("id"), len(v), el.get("type"), k)
            assert set(v) <= node_ids, "element %s refers to a missing node" % e.get("id")
        parts[el.get("name")] = len(el)
    node_sets = {s.get("name"): ids(s.text) for s in mesh.findall("NodeSet")}
    for name, v in node_sets.items():
        assert v and set(v) <= node_ids, "node set %s is empty or refers to a missing node" % name
    surfaces = set()
    for s in mesh.findall("Surface"):
        surfaces.add(s.get("name"))
        for f in s:
            assert len(ids(f.text)) == NODES_PER[f.tag], "surface %s facet %s: wrong node count" % (s.get("name"), f.tag)
    materials = {m.get("name"): m for m in root.find("Material")}
    for d in root.find("MeshDomains"):
        assert d.get("name") in parts, "domain %s is no element set" % d.get("name")
        assert d.get("mat") in materials, "domain %s: material %s missing" % (d.get("name"), d.get("mat"))
    maps = {}
    if root.find("MeshData") is not None:
        for data in root.find("MeshData"):
            assert data.tag == "ElementData" and data.get("type") == "scalar", "MeshData holds <%s>" % data.tag
            assert data.get("elem_set") in parts, "ElementData %s: element set missing" % data.get("name")
            lids = sorted(int(e.get("lid")) for e in data)
            assert lids == list(range(1, parts[data.get("elem_set")] + 1)), "ElementData %s: not one value per element" % data.get("name")
            maps[data.get("name")] = data
    for m in materials.values():
        for p in m:
            if p.get("type") == "map":
                assert p.text in maps, "material parameter %s maps the missing %s" % (p.tag, p.text)
    controllers = {lc.get("id") for lc in root.iter("load_controller")}
    for e in root.iter():
        if e.get("lc") is not None:
            assert e.get("lc") in controllers, "<%s lc=%s>: no such load controller" % (e.tag, e.get("lc"))
    if root.find("Boundary") is not None:
        for bc in root.find("Boundary"):
            assert bc.get("node_set") in node_sets, "bc %s: node set missing" % bc.get("name")
            if bc.get("type") == "zero displacement":
                assert [bc.find(t) is not None for t in ("x_dof", "y_dof", "z_dof")] == [True] * 3, "bc %s dofs" % bc.get("name")
            else:
                assert bc.get("type") == "prescribed displacement", "bc type %s" % bc.get("type")
                assert bc.find("dof").text in ("x", "y", "z") and bc.find("value") is not None, "bc %s" % bc.get("name")
    if root.find("Loads") is not None:
        for load in root.find("Loads"):
            assert load.get("surface") in surfaces, "load %s: surface missing" % load.get("name")
            assert load.get("type") in ("pressure", "traction"), "load type %s" % load.get("type")


try:
    check(sys.argv[1])
except (AssertionError, ET.ParseError, KeyError, ValueError, AttributeError) as e:
    print("FAIL: %s" % e)
    sys.exit(1)
print("OK")
