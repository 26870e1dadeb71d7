"""The standard dialects' wire facts, as pymavlink 2.4.50 ships them.

    dialect_facts.py write OUT_DIR   writes our wire-facts copy of every dialect XML pymavlink
                                     ships (definitions/mavlink/standard/)
    dialect_facts.py facts NAME      prints, as JSON, what pymavlink's own generated module
                                     pymavlink.dialects.v20.NAME holds: every message's id,
                                     CRC_EXTRA, fields in XML and wire order, types, array
                                     lengths, units, enums and displays, and every enum's values

`write` keeps every element and attribute of the MAVLink schema but the descriptions: the
text of `<description>`, `<field>`, `<entry>`, `<param>`, `<deprecated>`, `<superseded>` and
`<wip>`, and the comments. What is left is what goes on the wire and what names it.

`facts` reads pymavlink's generated module, not its XML: that module is what pymavlink users
run, so the test that compares it with our files proves our dialects identical to the code
they replace.
"""

import importlib
import json
import os
import sys
import xml.etree.ElementTree as ET

import pymavlink

SOURCE = os.path.join(os.path.dirname(pymavlink.__file__), "dialects", "v20")

# Elements whose text is a fact (the rest of the text in a dialect file is description).
TEXT_FACTS = {"include", "version", "dialect"}


def _emit(el, depth, out):
    pad = "  " * depth
    attrs = "".join(' %s="%s"' % (k, _escape(v)) for k, v in el.attrib.items())
    children = [c for c in el if c.tag != "description"]
    text = (el.text or "").strip() if el.tag in TEXT_FACTS else ""
    if children:
        out.append("%s<%s%s>" % (pad, el.tag, attrs))
        for c in children:
            _emit(c, depth + 1, out)
        out.append("%s</%s>" % (pad, el.tag))
    elif text:
        out.append("%s<%s%s>%s</%s>" % (pad, el.tag, attrs, _escape(text), el.tag))
    else:
        out.append("%s<%s%s/>" % (pad, el.tag, attrs))


def _escape(s):
    return (s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
            .replace('"', "&quot;"))


def write(out_dir):
    os.makedirs(out_dir, exist_ok=True)
    names = sorted(f for f in os.listdir(SOURCE) if f.endswith(".xml"))
    for name in names:
        root = ET.parse(os.path.join(SOURCE, name)).getroot()
        out = [
            '<?xml version="1.0"?>',
            "<!-- The wire facts of %s as pymavlink %s ships it: names, ids, types, order,"
            % (name, pymavlink.__version__ if hasattr(pymavlink, "__version__") else "2.4.50"),
            "     extensions, enum values and units. Descriptions are left out: pass the original",
            "     file with `--dialect FILE` for them. Regenerate with",
            "     tests/conformance/scripts/dialect_facts.py. -->",
        ]
        _emit(root, 0, out)
        with open(os.path.join(out_dir, name), "w", encoding="utf-8") as f:
            f.write("\n".join(out) + "\n")
    print("%d dialects written to %s" % (len(names), out_dir))


def facts(name):
    module = importlib.import_module("pymavlink.dialects.v20." + name)
    messages = []
    for msg_id in sorted(module.mavlink_map):
        c = module.mavlink_map[msg_id]
        messages.append({
            "id": msg_id,
            "name": c.msgname,
            "crc_extra": c.crc_extra,
            "fields": list(c.fieldnames),
            "wire_order": list(c.ordered_fieldnames),
            "types": list(c.fieldtypes),
            "array_lengths": list(c.array_lengths),
            "units": dict(c.fieldunits_by_name),
            "enums": dict(c.fieldenums_by_name),
            "displays": dict(c.fielddisplays_by_name),
            "length": c.unpacker.size,
        })
    enums = {}
    for enum_name, entries in module.enums.items():
        end = enum_name + "_ENUM_END"
        # mavgen adds NAME_ENUM_END (the highest value plus one) to every enum; it is not in
        # the XML.
        enums[enum_name] = {str(v): e.name for v, e in entries.items() if e.name != end}
    json.dump({"messages": messages, "enums": enums}, sys.stdout, sort_keys=True)
    sys.stdout.write("\n")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "write":
        write(sys.argv[2])
    elif len(sys.argv) == 3 and sys.argv[1] == "facts":
        facts(sys.argv[2])
    else:
        sys.exit(__doc__)
