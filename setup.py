"""Build step of the wheel: the user guides (docs/*.md) are copied into the
package as synth/docs, so an installed synth can print them (``synth help
TOPIC``; the commands' --help texts cite them that way).  Everything else
is in pyproject.toml."""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

DOCS = Path(__file__).resolve().parent / "docs"


class build_py_with_docs(build_py):
    """build_py, then docs/*.md -> BUILD_LIB/synth/docs/."""

    def run(self):
        super().run()
        if self.editable_mode:          # an editable install reads the checkout's docs/
            return
        out = Path(self.build_lib) / "synth" / "docs"
        out.mkdir(parents=True, exist_ok=True)
        for f in sorted(DOCS.glob("*.md")):
            shutil.copyfile(f, out / f.name)

    def get_outputs(self, include_bytecode=True):
        outs = super().get_outputs(include_bytecode)
        if not self.editable_mode:
            out = Path(self.build_lib) / "synth" / "docs"
            outs += [str(out / f.name) for f in sorted(DOCS.glob("*.md"))]
        return outs


setup(cmdclass={"build_py": build_py_with_docs})
