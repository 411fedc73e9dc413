"""Every XML file of the project is well-formed to a strict parser (issue 31, item 5).

MuJoCo's own parser accepts `--` inside a comment; the XML recommendation forbids it ("the string
'--' (double-hyphen) MUST NOT occur within comments", XML 1.0 §2.5), and Python's expat, lxml and
other strict parsers reject such a file. This reads every .xml under models/ and tests/ with
expat, which stops at the first error of any kind.
"""
import os
import unittest
import xml.parsers.expat

SOURCE = os.environ["MJSTEPPER_SOURCE_DIR"]


def xml_files():
    for top in ("models", "tests"):
        for folder, _, names in os.walk(os.path.join(SOURCE, top)):
            for name in sorted(names):
                if name.endswith(".xml"):
                    yield os.path.join(folder, name)


def parse_error(path):
    """None for a well-formed file; else expat's message with its line and column."""
    parser = xml.parsers.expat.ParserCreate()
    try:
        with open(path, "rb") as f:
            parser.ParseFile(f)
    except xml.parsers.expat.ExpatError as e:
        return str(e)
    return None


class WellFormedXml(unittest.TestCase):
    def test_every_xml_file_is_well_formed(self):
        files = list(xml_files())
        self.assertGreater(len(files), 10)  # the models are there to check
        bad = {os.path.relpath(p, SOURCE): e for p in files if (e := parse_error(p)) is not None}
        self.assertEqual(bad, {})

    def test_a_double_hyphen_in_a_comment_is_refused(self):
        # The check itself: the defect the models had.
        parser = xml.parsers.expat.ParserCreate()
        with self.assertRaises(xml.parsers.expat.ExpatError):
            parser.Parse(b"<!-- run it with --duration 4 --><mujoco/>", True)


if __name__ == "__main__":
    unittest.main()
