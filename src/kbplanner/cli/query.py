"""``kbplanner query``: run a named SPARQL query (or a query file) on a project, values bound.

``kbplanner query --list`` describes every named query; ``kbplanner query PROJECT NAME --bind var=value``
runs one with typed bindings; ``kbplanner query PROJECT --sparql FILE`` runs your own SELECT.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.core.errors import InputFileError, QueryError
from kbplanner.core.store_spec import OXIGRAPH, add_store_argument
from kbplanner.core.tables import FORMATS, iri_shortener, render

if TYPE_CHECKING:
    from rdflib.term import Identifier


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("query", help="run a named SPARQL query (or --sparql FILE) with bound values")
    p.add_argument("project", nargs="?", help="project directory")
    p.add_argument("name", nargs="?", help="named query (see --list)")
    p.add_argument("--list", action="store_true", help="describe every named query and its parameters")
    p.add_argument("--sparql", metavar="FILE", help="run the SELECT query in FILE instead of a named one")
    p.add_argument("--bind", action="append", default=[], metavar="VAR=VALUE",
                   help="bind a query variable (repeatable); for --sparql, <...> binds an IRI")
    p.add_argument("--scenario", help="scenario overlay to apply (default: the bare model)")
    add_store_argument(p, default=OXIGRAPH)  # same rows as rdflib, faster (tests/test_startup.py)
    p.add_argument("--format", choices=FORMATS, default="table")
    p.set_defaults(func=run)


def _pairs(binds: list[str]) -> dict[str, str]:
    out: dict[str, str] = {}
    for b in binds:
        if "=" not in b:
            raise QueryError(f"--bind {b!r} is not VAR=VALUE", fix="write e.g. --bind storeyLabel='Level 1'")
        k, v = b.split("=", 1)
        out[k.strip().lstrip("?")] = v
    return out


def _list() -> str:
    from kbplanner.core.named_queries import catalogue

    lines = []
    for name, q in sorted(catalogue().items()):
        lines.append(f"{name}\n    {q.description}")
        for p in q.params:
            lines.append(f"    --bind {p.name}=<{p.type}>  {p.description}")
        if q.columns:
            lines.append(f"    columns: {' '.join(q.columns)}")
    return "\n".join(lines) + "\n"


def run(args: argparse.Namespace) -> int:
    from kbplanner.core.named_queries import get_query, iri_term, result_rows, run_text, to_term
    from kbplanner.project import Project

    if args.list:
        sys.stdout.write(_list())
        return 0
    if not args.project:
        raise QueryError("no project given", fix="kbplanner query PROJECT NAME [--bind VAR=VALUE] "
                                                 "(or --list to see the named queries)")
    binds = _pairs(args.bind)
    if args.sparql:
        path = Path(args.sparql)
        if not path.is_file():
            raise InputFileError("query file not found", file=path, fix="give the path of a .rq file")
        text = path.read_text(encoding="utf-8")
        terms: dict[str, Identifier] = {}
        for k, v in binds.items():
            terms[k] = (iri_term(v[1:-1], param=k, query=str(path)) if v.startswith("<") and v.endswith(">")
                        else to_term(v, "xsd:string"))
        project = Project.load(args.project, scenario=args.scenario, store=args.store)
        try:
            result = result_rows(run_text(project.graph, text, terms))
        except Exception as exc:  # pyparsing / rdflib errors: report the file, not a traceback
            raise QueryError(f"the query could not be run: {exc}", element=str(path),
                             fix="check the SPARQL syntax (prefixes, braces) of the file") from None
    else:
        if not args.name:
            raise QueryError("no query name given", fix="kbplanner query --list shows the names")
        get_query(args.name)  # fail fast on an unknown name, before loading the project
        project = Project.load(args.project, scenario=args.scenario, store=args.store)
        result = project.query(args.name, **binds)
    sys.stdout.write(render(result.columns, result.rows, args.format, shorten=iri_shortener(project.base)))
    return 0
