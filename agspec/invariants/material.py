"""Material invariants: INV-CONSERVATION, INV-RECIPE, INV-ACCOUNTING (spec chapter 08)."""

from __future__ import annotations

from agspec.invariants.context import Context, Json, Violation, parse_item, reporter

# --------------------------------------------------------------------------- INV-CONSERVATION


def inv_conservation(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-CONSERVATION: every item has one consistent location; items appear only from a completed
    pick of a raw token or as a completed operation's declared output, and disappear only when
    consumed by their operation's completion or delivered (R-PICK, R-HANDOFF, R-COMPLETION,
    R-DELIVERY)."""
    ID = "INV-CONSERVATION"
    s = ctx.view(rec["state"])
    tick = s.t
    out, bad = reporter(ID, tick)

    # 1. one location per item, consistent with `items`
    for rid, r in s.robots.items():
        h = r.get("holding")
        if isinstance(h, list):
            bad(rid, f"robot {rid} holds {len(h)} items {h}; a robot holds at most one item")
    for item, robots in s.holders.items():
        ctx.count(ID)
        if len(robots) > 1:
            bad(item, f"item {item} is held by {len(robots)} robots ({', '.join(sorted(robots))})")
        where = s.items.get(item)
        if where is None:
            bad(item, f"robot {robots[0]} holds {item}, but `items` does not list it")
        elif where not in robots:
            bad(item, f"`items` places {item} at robot {where}, but robot {robots[0]} holds it")
        parsed = parse_item(item)
        recipe = ctx.recipe_of(s, parsed[0]) if parsed else None
        if parsed is None or recipe is None:
            bad(item, f"item {item} does not belong to a released product")
        elif parsed[1] not in recipe.tokens:
            bad(item, f"item {item}: token `{parsed[1]}` is neither a raw material nor an operation output of "
                      f"recipe `{recipe.id}`")
    for item, where in s.items.items():
        if item not in s.holders:
            bad(item, f"`items` places {item} at robot {where}, but no robot holds it")
        if item in ctx.gone_items:
            bad(item, f"item {item} reappears after it disappeared at t={ctx.gone_items[item]}")
    if prev is None:
        return out

    # 2.-3. every change of the item set or of a holder is explained by a completion
    p = ctx.view(prev["state"])
    tr = ctx.transition(prev, rec)
    now = {item: robots[0] for item, robots in s.holders.items()}
    was = {item: robots[0] for item, robots in p.holders.items()}
    created: dict[str, Json] = {}
    consumed: dict[str, Json] = {}
    moved: dict[str, Json] = {}
    for a in tr.completing:
        ctx.count(ID)
        kind = a.get("kind")
        if kind == "pick":
            created[a.get("item")] = a
        elif kind == "handoff":
            moved[a.get("item")] = a
        elif kind == "deliver":
            consumed[a.get("item")] = a
        elif kind == "operation":
            recipe = ctx.recipe_of(p, a.get("product")) or ctx.recipe_of(s, a.get("product"))
            op = recipe.ops.get(a.get("operation")) if recipe else None
            if op is None:
                continue
            for tok in op.inputs:
                consumed[f"{a['product']}:{tok}"] = a
            created[f"{a['product']}:{op.output}"] = a
    for item in sorted(set(now) - set(was)):
        a = created.get(item)
        if a is None:
            bad(item, f"item {item} appeared at robot {now[item]} without a completing pick or operation "
                      "that produces it")
            continue
        if item in consumed and consumed[item] is not a:
            bad(item, f"item {item} appeared while it should have been consumed by {consumed[item].get('id')}")
        if now[item] not in a.get("members", []):
            bad(item, f"item {item} produced by {a.get('id')} is held by {now[item]}, not by a member "
                      f"({', '.join(a.get('members', []))})")
        if a.get("kind") == "pick":
            parsed = parse_item(item)
            recipe = ctx.recipe_of(s, parsed[0]) if parsed else None
            if recipe is None or parsed[1] not in recipe.raw:
                bad(item, f"pick {a.get('id')} produced {item}, which is not a raw token of its product")
    for item in sorted(set(was) - set(now)):
        if item not in consumed:
            bad(item, f"item {item} held by {was[item]} disappeared without being consumed by a completing "
                      "operation or delivered")
        ctx.gone_items.setdefault(item, tick)
    for item, a in consumed.items():
        if a.get("kind") == "operation" and item in now and created.get(item) is not a:
            bad(item, f"operation {a.get('id')} completed but its input {item} still exists (at {now[item]})")
    for item, a in created.items():
        if a.get("kind") == "operation" and item not in now:
            bad(item, f"operation {a.get('id')} completed but its output {item} does not exist")
    for item in sorted(set(was) & set(now)):
        if was[item] == now[item]:
            continue
        a = moved.get(item)
        if a is None:
            bad(item, f"item {item} moved from {was[item]} to {now[item]} without a completing handoff")
        elif (a.get("sender"), a.get("receiver")) != (was[item], now[item]):
            bad(item, f"item {item} moved from {was[item]} to {now[item]}, but handoff {a.get('id')} goes from "
                      f"{a.get('sender')} to {a.get('receiver')}")
    for item, a in moved.items():
        if item in now and now[item] != a.get("receiver"):
            bad(item, f"handoff {a.get('id')} completed but {item} is at {now[item]}, not at its receiver "
                      f"{a.get('receiver')}")
    return out


# --------------------------------------------------------------------------- INV-RECIPE


def inv_recipe(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-RECIPE: completed and executing sets are disjoint, predecessors and XOR groups are respected,
    in-progress matches the operation activities, and delivery happens only after the terminal output
    exists (R-READY, R-ADMISSION, R-COMPLETION, R-XOR-CLOSURE, R-DELIVERY)."""
    ID = "INV-RECIPE"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    tick = s.t
    running: dict[int, list[str]] = {}
    for a in s.activities:
        if a.get("kind") == "operation":
            running.setdefault(a.get("product"), []).append(a.get("operation"))
    for pid, prod in s.products.items():
        ctx.count(ID)
        recipe = ctx.recipes.get(prod.get("recipe"))
        if recipe is None:
            out.append(Violation(ID, tick, str(pid), f"product {pid} has unknown recipe {prod.get('recipe')!r}"))
            continue
        done, doing = set(prod.get("completed", [])), set(prod.get("in_progress", []))
        xor = prod.get("xor") or {}

        def bad(msg):
            out.append(Violation(ID, tick, str(pid), f"product {pid} ({recipe.id}): {msg}"))

        if done & doing:
            bad(f"operations {sorted(done & doing)} are both completed and in progress")
        for op_id in sorted(done | doing):
            op = recipe.ops.get(op_id)
            if op is None:
                bad(f"unknown operation `{op_id}`")
                continue
            for pred in op.after:
                if pred in recipe.groups:
                    chosen = xor.get(pred)
                    if chosen is None or chosen not in done:
                        bad(f"`{op_id}` runs after XOR group `{pred}`, whose chosen alternative ({chosen}) is not "
                            "completed")
                elif pred not in done:
                    bad(f"`{op_id}` is {'completed' if op_id in done else 'in progress'} but its predecessor "
                        f"`{pred}` is not completed")
        for gid, alts in recipe.groups.items():
            used = [a for a in alts if a in done | doing]
            if len(used) > 1:
                bad(f"XOR group `{gid}` has several alternatives executed: {used}")
            elif used and xor.get(gid) != used[0]:
                bad(f"XOR group `{gid}`: alternative `{used[0]}` executed but the recorded choice is {xor.get(gid)}")
        for gid in xor:
            if gid not in recipe.groups:
                bad(f"XOR choice for unknown group `{gid}`")
        if sorted(doing) != sorted(running.get(pid, [])):
            bad(f"in progress {sorted(doing)} but operation activities for {sorted(running.get(pid, []))}")
        if prod.get("delivered_at") is not None:
            producers = recipe.producers(recipe.terminal)
            if not any(op in done for op in producers):
                bad(f"delivered at {prod['delivered_at']} although no operation producing `{recipe.terminal}` "
                    "completed")
            if f"{pid}:{recipe.terminal}" in s.holders:
                bad(f"delivered but its terminal item is still held by {s.holders[f'{pid}:{recipe.terminal}']}")
            if prod["delivered_at"] > tick:
                bad(f"delivered_at {prod['delivered_at']} lies in the future of t={tick}")
    for a in s.activities:
        if a.get("kind") != "deliver":
            continue
        pid = a.get("product")
        recipe = ctx.recipe_of(s, pid)
        if recipe is None:
            continue
        item = f"{pid}:{recipe.terminal}"
        prod = s.products[pid]
        if a.get("item") not in (None, item) or s.holders.get(item, [None])[0] not in a.get("members", []):
            out.append(Violation(ID, tick, a.get("id"), f"delivery {a.get('id')} of product {pid} does not carry its "
                                                       f"terminal item {item}"))
        if not any(op in prod.get("completed", []) for op in recipe.producers(recipe.terminal)):
            out.append(Violation(ID, tick, a.get("id"), f"delivery {a.get('id')} started before product {pid}'s "
                                                       "terminal operation completed"))
    return out


# --------------------------------------------------------------------------- INV-ACCOUNTING


def inv_accounting(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-ACCOUNTING: released, delivered and lost releases never decrease; wip = released - delivered =
    number of undelivered products <= wip_cap; one opportunity per release epoch; releases follow the
    realization (R-RELEASE, R-DELIVERY, R-COMPLETION)."""
    ID = "INV-ACCOUNTING"
    state = rec["state"]
    s = ctx.view(state)
    tick = s.t
    ctx.count(ID)
    out, bad = reporter(ID, tick)

    released, delivered = state.get("released"), state.get("delivered")
    wip, lost = state.get("wip"), state.get("lost_releases", 0)
    undelivered = sum(1 for p in s.products.values() if p.get("delivered_at") is None)
    n_delivered = sum(1 for p in s.products.values() if p.get("delivered_at") is not None)
    if not all(isinstance(x, int) for x in (released, delivered, wip, lost)):
        bad(None, f"counters released={released!r} delivered={delivered!r} wip={wip!r} lost={lost!r} are not integers")
        return out
    if wip != released - delivered:
        bad(None, f"wip {wip} != released {released} - delivered {delivered}")
    if wip != undelivered:
        bad(None, f"wip {wip} != {undelivered} released undelivered products")
    if released != len(s.products) or sorted(s.products) != list(range(len(s.products))):
        bad(None, f"released = {released} but the state lists products {sorted(s.products)}")
    if delivered != n_delivered:
        bad(None, f"delivered = {delivered} but {n_delivered} products are delivered")
    if not (0 <= delivered <= released) or lost < 0:
        bad(None, f"impossible counters released={released} delivered={delivered} lost={lost}")
    if wip > ctx.wip_cap:
        bad(None, f"wip {wip} exceeds the WIP cap {ctx.wip_cap}")
    for pid, prod in s.products.items():
        if pid < len(ctx.realization_products):
            spec = ctx.realization_products[pid]
            if prod.get("recipe") != spec.get("recipe") or prod.get("due") != prod.get("released_at", 0) + spec.get("due_offset", 0):
                bad(str(pid), f"product {pid} ({prod.get('recipe')}, due {prod.get('due')}) does not follow realization "
                              f"entry {pid} ({spec.get('recipe')}, due offset {spec.get('due_offset')})")
        else:
            bad(str(pid), f"product {pid} is not in the realization ({len(ctx.realization_products)} products)")
    if prev is None:
        forced = 0 if (ctx.mode == "batch" and not ctx.batch_size) else 1
        if released + lost != forced:
            bad(None, f"the initial state has released {released} + lost {lost} != {forced} opportunity at t=0")
        return out
    pstate = prev["state"]
    p = ctx.view(pstate)
    t = int(rec.get("t", p.t))
    for key in ("released", "delivered", "lost_releases"):
        if isinstance(pstate.get(key), int) and state.get(key, 0) < pstate[key]:
            bad(None, f"{key} decreased from {pstate[key]} to {state.get(key)}")
    opportunity = (t + 1) % ctx.interval == 0 and not (
        ctx.mode == "batch" and int(pstate.get("released", 0)) >= int(ctx.batch_size or 0))
    step = (released + lost) - (int(pstate.get("released", 0)) + int(pstate.get("lost_releases", 0)))
    if step != (1 if opportunity else 0):
        bad(None, f"released + lost grew by {step} at t={t + 1}, which is "
                  f"{'a' if opportunity else 'not a'} release opportunity (interval {ctx.interval})")
    for pid, prod in s.products.items():
        if pid in p.products:
            continue
        if prod.get("released_at") != t + 1 or pid != pstate.get("released"):
            bad(str(pid), f"new product {pid} released at {prod.get('released_at')}; expected id "
                          f"{pstate.get('released')} released at {t + 1}")
    tr = ctx.transition(prev, rec)
    delivering = {a.get("product") for a in tr.completing if a.get("kind") == "deliver"}
    for pid, prod in s.products.items():
        before = p.products.get(pid)
        if prod.get("delivered_at") is not None and (before is None or before.get("delivered_at") is None):
            if pid not in delivering or prod["delivered_at"] != t + 1:
                bad(str(pid), f"product {pid} became delivered (at {prod['delivered_at']}) without a delivery "
                              f"completing at {t + 1}")
    for pid in delivering:
        if (s.products.get(pid) or {}).get("delivered_at") is None:
            bad(str(pid), f"a delivery of product {pid} completed but the product is not delivered")
    return out
