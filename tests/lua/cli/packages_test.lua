-- Controller packages as a user meets them: `use` in a .dca file, `dca check`, `dca types --package`, and the
-- errors of each kind with their file:line:col, both packages, the symbol or both versions named; a leaf whose
-- constructor or Init throws ends ABORTED with the exception's text and nothing is left running. The packages
-- are tests/packages/'s, in $DCA_TEST_PACKAGES_DIR (on no default search path).
local T = require "dca.testing"
local suite = T.suite("packages")

local dir = os.getenv("DCA_TEST_PACKAGES_DIR") or error("DCA_TEST_PACKAGES_DIR is not set")

-- `dca ARGS` with the test packages on the search path. --> output, exit code
local function dca(args, rc, ...)
  local out, code = T.sh("DCA_CONTROLLER_PATH=" .. dir .. " " .. T.exe .. " " .. args)
  if rc ~= nil and code ~= rc then error(string.format("dca %s: exit code %s, not %d:\n%s", args, code, rc, out), 0) end
  for _, fragment in ipairs({ ... }) do T.contains(out, fragment, "dca " .. args) end
  return out, code
end

local function system(uses, body)
  return T.tmpfile(uses .. "\nprocess main() {\n" .. body .. "\n}\n")
end

suite:case("a_used_packages_types_are_checked_like_built_ins", function()
  local path = system("use pkg_ok;", [[
  instantiated_processes { a instof PkgScale("h1", 3); b instof Gain("h1", 1); }
  internal_connections(a, run) { a, Out -> b, Inn; }
  internal_event_actions { a[run], b }]])
  dca("check " .. path, 1, path .. ":4:47: main.b: no input 'Inn' on b (Gain); inputs are: In")
  T.write(path, (T.read(path):gsub("Inn", "In"):gsub("a, Out", "a, Outt")))
  dca("check " .. path, 1, path .. ":4:37: main.a: no output 'Outt' on a (PkgScale); outputs are: Out")
  os.remove(path)
end)

suite:case("dca_graph_draws_a_system_of_package_types", function()
  local path = system("use pkg_ok;", [[
  instantiated_processes { a instof PkgScale("h1", 3); b instof PkgScale("h1"); }
  internal_connections(a, run) { a, Out -> b, In; }
  internal_event_actions { a[run], b }]])
  dca("graph " .. path, 0, "digraph", "PkgScale")
  os.remove(path)
end)

suite:case("a_type_from_a_package_the_file_does_not_use_is_unknown", function()
  local path = system("", [[  instantiated_processes { a instof PkgScale("h1"); }
  internal_event_actions { a }]])
  dca("check " .. path, 1, path .. ":3:37: main.a: unknown process type 'PkgScale' (not defined in this file, " ..
      "not built in, not in a package the file uses; packages it could use: door, joint_control, pkg_builtin, ")
  os.remove(path)
end)

-- A package whose static initialiser faults kills the process that loads it (its code runs in dlopen), but not
-- silently: the line before the signal names the package and its file. (Before: `dca check` died with no word.)
suite:case("a_package_that_crashes_while_loading_is_named_before_the_process_dies", function()
  local path = system("use pkg_crash;", "  instantiated_processes { a instof PkgCrash(\"h1\"); }\n  internal_event_actions { a }")
  local out, code = T.sh("DCA_CONTROLLER_PATH=" .. dir .. "/crash " .. T.exe .. " check " .. path)
  T.contains(out, "dca: package 'pkg_crash' (" .. dir .. "/crash/pkg_crash.dca.so) crashed while loading " ..
             "(in its static initialisers or add_types)", "dca check")
  T.ok(code ~= 0 and code ~= 1, "it died by the signal, exit code " .. tostring(code))
  os.remove(path)
end)

suite:case("a_package_not_found_is_an_error_at_its_use_naming_every_path_searched", function()
  local path = system("use pkg_ok,\n    nosuch;", "  instantiated_processes { a instof PkgScale(\"h1\"); }\n  internal_event_actions { a }")
  dca("check " .. path, 1, path .. ":2:5: use: package 'nosuch' not found (searched: " .. dir .. "/nosuch.dca.so, ",
      "/lib/dca/controllers/nosuch.dca.so", "/packages/nosuch.dca.so")
  os.remove(path)
end)

suite:case("a_type_two_packages_define_is_written_with_its_package", function()
  local path = system("use pkg_ok, pkg_twin;", "  instantiated_processes { a instof PkgScale(\"h1\"); }\n  internal_event_actions { a }")
  dca("check " .. path, 1, path .. ":3:37: main.a: type 'PkgScale' is defined by packages pkg_ok and pkg_twin: " ..
      "write pkg_ok.PkgScale or pkg_twin.PkgScale")
  os.remove(path)
  -- each qualified, both in one system: the nodes load the package each names (k 2, then k 3: Out = 6 Count)
  path = system("use pkg_ok, pkg_twin;", [[
  instantiated_processes {
    n instof Counter("h1", 0.01);
    a instof pkg_ok.PkgScale("h1", 2);
    b instof pkg_twin.PkgScale("h1", 3);
    at60 instof Threshold("h1", 60, "rising");
    limit instof Deadline("h1", 30);
  }
  internal_connections(a, run) { n, Count -> a, In; a, Out -> b, In; }
  internal_connections(b, run) { b, Out -> at60, In; }
  internal_event_actions { (at60 # limit) # (a[run], b[run], n) }]])
  dca("check " .. path, 0)
  dca("graph --svg -o /dev/null " .. path, nil)
  dca("run " .. path, 0, "main: DONE")
  os.remove(path)
  -- a file that uses one of them writes the name alone
  path = system("use pkg_twin;", "  instantiated_processes { a instof PkgScale(\"h1\"); }\n  internal_event_actions { a }")
  dca("check " .. path, 0)
  os.remove(path)
  dca("types PkgScale", 0, "PkgScale(host, k=2, period=0)    (package pkg_ok)",
      "PkgScale(host, k=2, period=0)    (package pkg_twin)")
  local out = dca("types pkg_twin.PkgScale", 0, "(package pkg_twin)")
  T.ok(not out:find("(package pkg_ok)", 1, true), out)
end)

suite:case("a_package_parameters_range_is_checked_at_its_literal", function()
  local path = system("use pkg_positive;", "  instantiated_processes { a instof PkgPositive(\"h1\", -0.005); }\n" ..
    "  internal_event_actions { a }")
  dca("check " .. path, 1, path .. ":3:55: main.a: parameter 'k' of PkgPositive must be positive, got -0.005")
  os.remove(path)
end)

suite:case("a_missing_symbol_another_dcas_package_and_a_library_that_is_no_package_are_refused", function()
  local path = system("use pkg_missing;\nuse pkg_old;\nuse pkg_none;", "  instantiated_processes { }\n  internal_event_actions { }")
  dca("check " .. path, 1,
      path .. ":1:5: use: package 'pkg_missing' (" .. dir .. "/pkg_missing.dca.so): missing symbol 'dca::missing_for_tests(double)'",
      path .. ":2:5: use: package 'pkg_old' (" .. dir .. "/pkg_old.dca.so) was built against dca 0.0.9",
      "; this is dca ",
      path .. ":3:5: use: package 'pkg_none' (" .. dir .. "/pkg_none.dca.so) is not a dca controller package")
  os.remove(path)
end)

suite:case("use_is_a_statement_before_the_processes_with_labelled_errors", function()
  local path = T.tmpfile("use 3;\n")
  dca("check " .. path, 1, path .. ":1:5: expected a package name after 'use' (write 'use mylab;'), found '3'")
  T.write(path, "use a b;\n")
  dca("check " .. path, 1, path .. ":1:7: expected ',' and another package, or ';' to end 'use', found 'b'")
  T.write(path, "process main() { internal_event_actions { } }\nuse a;\n")
  dca("check " .. path, 1, path .. ":2:1: 'use' comes before the first process")
  T.write(path, "use pkg_ok;\nuse pkg_ok;\nprocess main() { instantiated_processes { a instof PkgScale(\"h\"); } internal_event_actions { a } }\n")
  dca("check " .. path, 1, path .. ":2:5: use: package 'pkg_ok' is already used at line 1")
  os.remove(path)
end)

suite:case("dca_types_lists_a_packages_types", function()
  local out = dca("types --package pkg_ok", 0, "PkgScale(host, k=2, period=0)    (package pkg_ok)", "in     In")
  T.ok(not out:find("Gain(host", 1, true), "only the package's types:\n" .. out)
  dca("types --package nosuch", 1, "package 'nosuch' not found")
  out = T.dca("types", 0, "Gain(host", "(package door)", "ForceThreshold(host")
  -- A named type is searched in every package on the path; those that fail to load matter only when it is not found.
  dca("types PkgOtherCc", 0, "PkgOtherCc(host, k=2, period=0)    (package pkg_other_cc)",
      "param  period     number   seconds between ticks; 0: on each sample  (>= 0)")
  dca("types NoSuchType", 1, "unknown controller type 'NoSuchType'", "packages on the search path that did not load:",
      "pkg_missing")
end)

-- No process of this test's runs left (their argv name the type).
local function none_left(type_name)
  -- "[P]kgThrows" matches the type's name but not this pgrep's own command line
  local out = T.sh("pgrep -f -- '--type [" .. type_name:sub(1, 1) .. "]" .. type_name:sub(2) .. "' || true")
  T.eq(out, "", "processes left running")
end

-- A system where leaf `bad` of package `pkg`'s type `ty` ends ABORTED saying `text` while a Timer waits: the run
-- ends ABORTED at main.bad (exit code 1) and no process of it is left.
local function aborts(pkg, ty, text)
  local path = system("use " .. pkg .. ";", "  instantiated_processes { bad instof " .. ty .. [[("h1"); wait instof Timer("h1", 60); }
  internal_event_actions { wait # bad }]])
  local out = dca("run " .. path, 1, "main: ABORTED at main.bad: " .. ty .. ": " .. text)
  T.kept_logs(out)
  T.ok(not out:find("main.bad: main.bad", 1, true) and not out:find(ty .. " main.bad", 1, true),
       "the leaf's path is said once:\n" .. out)
  none_left(ty)
  os.remove(path)
end

suite:case("a_constructor_that_throws_ends_its_leaf_ABORTED_with_the_text_nothing_left_running", function()
  aborts("pkg_throws", "PkgThrows", "its constructor failed: cannot open the device /dev/nonexistent")
end)

suite:case("an_Init_that_throws_ends_its_leaf_ABORTED_with_the_text_nothing_left_running", function()
  aborts("pkg_init_throws", "PkgInitThrows", "on_configure failed: calibration file /nonexistent/cal.yaml is missing")
end)

suite:case("a_node_loads_packages_by_name_only_from_its_search_path", function()
  local out = dca("node --type PkgScale --name /x --daemon 127.0.0.1:1 --package ../pkg_ok", 1)
  T.contains(out, "'../pkg_ok' is not a package name")
  out = dca("node --type PkgScale --name /x --daemon 127.0.0.1:1 --package nosuch", 1)
  T.contains(out, "package 'nosuch' not found")
end)

return suite:run(...)
