"""``gfc skills ...``: list, show, push, pull, verify, prune and alias skill versions.

Every command takes ``--store PATH_OR_URL`` (or ``GFC_SKILL_STORE``); the default is the library
shipped inside the package, which may be empty.
"""

from __future__ import annotations

import json
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from skill_store.errors import IntegrityError, SkillStoreError
from skill_store.names import parse_ref, validate_name
from skill_store.store import DEFAULT_LIBRARY, SkillStore
from skill_store.transfer import read_checkpoint_folder, write_checkpoint_folder

skills_app = typer.Typer(
    help=(
        "Manage the skill store: versioned, integrity-checked skill model checkpoints.\n\n"
        "A reference is NAME (alias 'latest', else the highest version), NAME@VERSION or "
        "NAME@ALIAS. The store is a folder or an fsspec URL:\n\n"
        "  gfc skills list --store ./skills\n\n"
        "  GFC_SKILL_STORE=s3://bucket/skills gfc skills show pick.hammer@production\n\n"
        "  gfc skills verify"
    ),
    no_args_is_help=True,
)

out = Console()
err = Console(stderr=True)

Store = Annotated[
    str,
    typer.Option(
        "--store",
        envvar="GFC_SKILL_STORE",
        help="Store folder or fsspec URL (s3://..., memory://...).",
        show_default="the library shipped with the package",
    ),
]
DEFAULT_STORE = str(DEFAULT_LIBRARY)


def _fail(error: Exception) -> typer.Exit:
    err.print(f"[red]error:[/red] {error}", highlight=False)
    return typer.Exit(1)


@skills_app.command("list")
def list_command(
    name: Annotated[str | None, typer.Argument(help="Show this skill's versions.")] = None,
    store: Store = DEFAULT_STORE,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """List skills, or one skill's versions with their aliases.

    Examples:

      gfc skills list

      gfc skills list pick.hammer --store ./skills
    """
    try:
        skill_store = SkillStore(store)
        if name is None:
            rows = [(n, skill_store.state(n)) for n in skill_store.skills()]
            if as_json:
                listing = {n: {"versions": list(s.versions), "aliases": s.aliases} for n, s in rows}
                out.print_json(json.dumps(listing))
                return
            table = Table("skill", "versions", "aliases", title=f"skills in {store}")
            for n, state in rows:
                aliases = ", ".join(f"{a}->{v}" for a, v in sorted(state.aliases.items()))
                table.add_row(n, ", ".join(map(str, state.versions)), aliases)
            out.print(table if rows else f"no skills in {store}")
            return
        state = skill_store.state(validate_name(name))
        manifests = []
        for v in state.versions:
            try:
                manifests.append(skill_store.manifest(f"{name}@{v}"))
            except IntegrityError as error:  # list the rest; verify says what is wrong
                err.print(f"[red]{name}@{v} is unreadable:[/red] {error}", highlight=False)
        if as_json:
            versions = [
                {
                    "version": m.version,
                    "created_at": m.created_at.isoformat(),
                    "sha256": m.weights.sha256,
                    "aliases": sorted(a for a, v in state.aliases.items() if v == m.version),
                }
                for m in manifests
            ]
            out.print_json(json.dumps({"name": name, "versions": versions}))
            return
        table = Table("version", "created (UTC)", "sha256", "aliases", title=name)
        for m in manifests:
            aliases = ", ".join(sorted(a for a, v in state.aliases.items() if v == m.version))
            table.add_row(
                str(m.version), m.created_at.strftime("%Y-%m-%d %H:%M:%S"), m.weights.sha256[:12], aliases
            )
        out.print(table if manifests else f"no versions of {name} in {store}")
    except SkillStoreError as error:
        raise _fail(error) from None


@skills_app.command()
def show(
    ref: Annotated[str, typer.Argument(help="NAME, NAME@VERSION or NAME@ALIAS.")],
    store: Store = DEFAULT_STORE,
) -> None:
    """Print the manifest of the version a reference resolves to.

    Examples:

      gfc skills show pick.hammer              # alias 'latest', else the highest version

      gfc skills show pick.hammer@3

      gfc skills show pick.hammer@production
    """
    try:
        manifest = SkillStore(store).manifest(ref)
    except SkillStoreError as error:
        raise _fail(error) from None
    out.print_json(manifest.model_dump_json())


@skills_app.command()
def push(
    source: Annotated[str, typer.Argument(help="Folder (or URL) with model.safetensors and manifest.json.")],
    name: Annotated[
        str | None, typer.Option(help="Publish under this name (default: the manifest's).")
    ] = None,
    alias: Annotated[
        list[str] | None, typer.Option("--alias", help="Move this alias to the new version (repeatable).")
    ] = None,
    store: Store = DEFAULT_STORE,
) -> None:
    """Publish a checkpoint folder as the next version of a skill (checked before publishing).

    Examples:

      gfc skills push runs/pick_hammer/ --store ./skills

      gfc skills push export/ --name pick.hammer --alias latest --alias production
    """
    try:
        manifest, data = read_checkpoint_folder(source)
        if name is not None:
            manifest = manifest.model_copy(update={"name": validate_name(name)})
        version = SkillStore(store).publish_checkpoint(manifest, data, aliases=alias or [])
    except SkillStoreError as error:
        raise _fail(error) from None
    out.print(f"published {manifest.name}@{version} to {store}", highlight=False)


@skills_app.command()
def pull(
    ref: Annotated[str, typer.Argument(help="NAME, NAME@VERSION or NAME@ALIAS.")],
    dest: Annotated[str, typer.Argument(help="Folder (or URL) to write the checkpoint into.")],
    store: Store = DEFAULT_STORE,
    force: Annotated[bool, typer.Option(help="Overwrite a checkpoint already in DEST.")] = False,
) -> None:
    """Copy one version (checked) out of the store into a folder.

    Examples:

      gfc skills pull pick.hammer@production ./pick_hammer/

      gfc skills pull pick.hammer@3 ./local --store s3://bucket/skills
    """
    try:
        manifest, data = SkillStore(store).weights_bytes(ref)
        write_checkpoint_folder(dest, manifest, data, overwrite=force)
    except SkillStoreError as error:
        raise _fail(error) from None
    out.print(f"wrote {manifest.ref} to {dest}", highlight=False)


@skills_app.command()
def verify(
    refs: Annotated[
        list[str] | None, typer.Argument(help="References to check (a bare NAME: all its versions).")
    ] = None,
    store: Store = DEFAULT_STORE,
) -> None:
    """Check versions' sha256 and manifests against their weights; exit 1 if any fails.

    Examples:

      gfc skills verify                        # every version of every skill

      gfc skills verify pick.hammer move.empty@2
    """
    try:
        results = SkillStore(store).verify(refs or None)
    except SkillStoreError as error:
        raise _fail(error) from None
    for result in results:
        if result.ok:
            out.print(f"[green]ok[/green]    {result.ref}", highlight=False)
        else:
            out.print(f"[red]FAIL[/red]  {result.ref}: {result.problem}", highlight=False)
    failed = sum(not r.ok for r in results)
    out.print(f"{len(results)} checked, {failed} failed", highlight=False)
    if failed:
        raise typer.Exit(1)


@skills_app.command()
def prune(
    names: Annotated[list[str] | None, typer.Argument(help="Skills to prune (default: every skill).")] = None,
    keep: Annotated[int, typer.Option(min=1, help="Newest versions to keep per skill.")] = 1,
    dry_run: Annotated[bool, typer.Option("--dry-run", help="Only say what would be removed.")] = False,
    reason: Annotated[str | None, typer.Option(help="Why, for the audit log.")] = None,
    store: Store = DEFAULT_STORE,
) -> None:
    """Remove superseded versions: all but the newest KEEP of each skill. Versions an alias
    points at always stay; each removal is logged in the skill's audit log, and a removed
    version's number is never reused.

    Examples:

      gfc skills prune --dry-run               # what would go, store-wide

      gfc skills prune pick.pot --keep 2 --reason "v1-v3 superseded by the bigger budget"
    """
    try:
        skill_store = SkillStore(store)
        total = 0
        for name in names or skill_store.skills():
            gone = skill_store.prunable(name, keep) if dry_run else skill_store.prune(name, keep, reason)
            total += len(gone)
            if gone:
                verb = "would remove" if dry_run else "removed"
                out.print(f"{name}: {verb} {', '.join(f'@{v}' for v in gone)}", highlight=False)
    except SkillStoreError as error:
        raise _fail(error) from None
    out.print(f"{total} version(s) {'to remove' if dry_run else 'removed'}", highlight=False)


@skills_app.command("alias")
def alias_command(
    name: Annotated[str, typer.Argument(help="Skill name.")],
    alias: Annotated[str | None, typer.Argument(help="Alias to move (or remove).")] = None,
    version: Annotated[str | None, typer.Argument(help="Version or alias to point it at.")] = None,
    remove: Annotated[bool, typer.Option("--remove", help="Delete the alias.")] = False,
    reason: Annotated[str | None, typer.Option(help="Why, for the audit log.")] = None,
    store: Store = DEFAULT_STORE,
) -> None:
    """Move an alias to a version, remove it, or (with only NAME) show aliases and the audit log.

    Every change is appended to the skill's audit log.

    Examples:

      gfc skills alias pick.hammer production 3 --reason "better success rate"

      gfc skills alias pick.hammer latest production     # point 'latest' where 'production' is

      gfc skills alias pick.hammer canary --remove

      gfc skills alias pick.hammer                        # aliases and audit log
    """
    try:
        skill_store = SkillStore(store)
        validate_name(name)
        if alias is None:
            for a, v in sorted(skill_store.aliases(name).items()):
                out.print(f"{a} -> {name}@{v}", highlight=False)
            for entry in skill_store.audit_log(name):
                change = {
                    "published": f"published version {entry.version}",
                    "alias_moved": f"{entry.alias}: {entry.previous or '-'} -> {entry.version}",
                    "alias_removed": f"{entry.alias}: {entry.previous} -> removed",
                }[entry.event]
                why = f" ({entry.reason})" if entry.reason else ""
                out.print(f"{entry.at:%Y-%m-%d %H:%M:%S}  {entry.actor}  {change}{why}", highlight=False)
            return
        if remove:
            if version is not None:
                raise typer.BadParameter("--remove takes no VERSION")
            skill_store.remove_alias(name, alias, reason)
            out.print(f"removed {name}@{alias}", highlight=False)
            return
        if version is None:
            raise typer.BadParameter("give the VERSION (or alias) to point it at, or --remove")
        entry = skill_store.set_alias(str(parse_ref(f"{name}@{version}")), alias, reason)
        out.print(f"{name}@{alias} -> {name}@{entry.version}", highlight=False)
    except SkillStoreError as error:
        raise _fail(error) from None


@skills_app.command("check")
def check_command(
    name: Annotated[str, typer.Argument(help="Skill model reference, e.g. pick.hammer or pick.hammer@3.")],
    n: Annotated[int, typer.Option("-n", min=1, help="Fresh scenes to try.")] = 50,
    json_file: Annotated[str | None, typer.Option("--json", help="Write the report as JSON here.")] = None,
    processes: Annotated[int, typer.Option(min=1, help="Simulator processes.")] = 2,
    store: Store = DEFAULT_STORE,
) -> None:
    """Execute the model's sampled actions alone in the simulator on N fresh scenes.

    Prints the hit rate, the hit rate of uniform random actions on the same scenes and the
    success rate of the data the model was trained on. JSON keys: hit_rate, random_hit_rate,
    trials, data_success_rate, failures, random_failures.

    Example: gfc skills check pick.hammer -n 50 --json pick.hammer.json
    """
    from gfc.data.scenarios import SCENARIOS
    from gfc.pool import LocalPool
    from gfc.skills.check import check_model

    try:
        ref = parse_ref(name)
    except SkillStoreError as error:
        raise _fail(error) from None
    if ref.name not in SCENARIOS:
        err.print(f"error: no scene sampler for {ref.name!r}; have: {', '.join(sorted(SCENARIOS))}")
        raise typer.Exit(2)
    try:
        with LocalPool(processes, keep_alive=True) as pool:
            report = check_model(ref.name, n, store, pool, ref=name)
    except SkillStoreError as error:
        raise _fail(error) from None
    out.print(
        f"{ref.name}@{report['version']}: hit rate {report['hit_rate']:.0%} over {report['trials']} scenes, "
        f"uniform random {report['random_hit_rate']:.0%}, data {report['data_success_rate']}",
        highlight=False,
    )
    if json_file is not None:
        with open(json_file, "w") as fh:
            json.dump(report, fh, indent=2)
