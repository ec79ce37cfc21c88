-- dca.load: a .dca file read, parsed, checked, built and turned into its spec; every error as text.
local T = require "dca.testing"
local load = require "dca.load"
local suite = T.suite("load")

local door = T.src .. "/worlds/door/systems/door_open.dca"

suite:case("file_gives_the_ast_and_the_tree_of_main", function()
  local ast, tree = load.file(door)
  T.ok(ast and ast.by_name.DoorOpenSystem, tostring(tree))
  T.eq({ tree.path, tree.kind }, { "main", "group" })
end)

suite:case("file_without_main_gives_no_tree_unless_a_root_is_asked_for", function()
  local path = T.tmpfile("process P(h) { instantiated_processes { t instof Timer(h, 1); } internal_event_actions { t } }\n")
  local ast, tree = load.file(path)
  T.ok(ast)
  T.eq(tree, nil)
  local none, err = load.file(path, { root = "Q" })
  T.eq(none, nil)
  T.contains(err, ":1:1: Q: no process 'Q' to run as the root")
  os.remove(path)
end)

suite:case("errors_come_as_text_with_file_line_col", function()
  local path = T.tmpfile("process main() {\n  instantiated_processes { a instof T(); }\n  internal_event_actions { a }\n}\n")
  local ast, err = load.file(path, { registry = false })
  T.eq(ast, nil)
  T.contains(err, path .. ":2:28: main.a: leaf 'a' (T) has no host")
  T.contains(err, path .. ": 1 error")
  os.remove(path)
  local none, rerr = load.file("/nonexistent/x.dca")
  T.eq(none, nil)
  T.contains(rerr, "dca: cannot read /nonexistent/x.dca")
end)

suite:case("the_registry_checks_leaf_types_unless_turned_off", function()
  local path = T.tmpfile("process main() { instantiated_processes { x instof NoSuchType(\"h\"); }\n" ..
                         "  internal_event_actions { x } }\n")
  T.ok(load.file(path, { registry = false }))
  if load.registry() then
    local ast, err = load.file(path)
    T.eq(ast, nil)
    T.contains(err, "unknown process type 'NoSuchType'")
  end
  os.remove(path)
end)

suite:case("spec_gives_the_validated_spec_of_the_root", function()
  local spec, tree, ast = load.spec(door)
  T.ok(spec, tree)
  T.eq(spec.path, "main")
  T.ok(tree and ast)
  local path = T.tmpfile("process P(h) { instantiated_processes { t instof Timer(h, 1); } internal_event_actions { t } }\n")
  local none, err = load.spec(path)
  T.eq(none, nil)
  T.eq(err, path .. ": no process 'main' to run")
  os.remove(path)
end)

return suite:run(...)
