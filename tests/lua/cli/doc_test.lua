-- The CLI's generated reference (dca.cli.doc): `dca completion bash`, completing in a real bash, and the manual
-- page dca(1) built from the commands' usage texts.
local T = require "dca.testing"
local doc = require "dca.cli.doc"
local suite = T.suite("doc")

local dca, src = T.exe, T.src

-- What bash completes for the words `line` (the last one being typed), with the script `dca completion bash`.
local function complete(script, line)
  local words = {}
  for w in line:gmatch("%S+") do words[#words + 1] = "'" .. w .. "'" end
  if line:sub(-1) == " " then words[#words + 1] = "''" end
  local cmd = string.format("bash --norc --noprofile -c 'source %s; COMP_WORDS=(%s); COMP_CWORD=%d; _dca; "
    .. "printf \"%%s\\n\" \"${COMPREPLY[@]}\"'", script, table.concat(words, " "):gsub("'", "'\\''"), #words - 1)
  local out, rc = T.sh(cmd)
  T.eq(rc, 0, cmd .. "\n" .. out)
  local got = {}
  for w in out:gmatch("%S+") do got[#got + 1] = w end
  return got
end

suite:case("bash_completes_commands_options_and_help_topics", function()
  local script = T.tmpname(".bash")
  local out, rc = T.sh(dca .. " completion bash > " .. script)
  T.eq(rc, 0, out)
  T.eq(select(2, T.sh("bash -n " .. script)), 0, "the script parses")
  T.eq(complete(script, "dca ru"), { "run" })
  T.eq(complete(script, "dca sc"), { "scenario" })
  T.eq(complete(script, "dca run --pla"), { "--placement" })
  T.eq(complete(script, "dca run --record-"), { "--record-compression", "--record-ports", "--record-split" })
  T.eq(complete(script, "dca check --ver"), { "--verify" })
  T.eq(complete(script, "dca help tr"), { "trace" })
  -- options a usage text only mentions (trace's text names `dca run --trace`) are not the command's own
  T.eq(complete(script, "dca trace --"), { "--help" })
  T.eq(complete(script, "dca --v"), { "--version" })
  os.remove(script)
  out, rc = T.sh(dca .. " completion zsh")
  T.eq(rc, 2)
  T.contains(out, "dca completion: no completion for 'zsh' (only bash)")
end)

suite:case("options_are_the_synopsis_and_the_described_ones", function()
  T.eq(doc.options("usage: dca x FILE [--root NAME] [--svg]\n       dca x --list\n\nText on `dca y --other`, "
    .. "and --mentioned.\n  --root NAME   the root\n  --deep        described\n"), { "--deep", "--list", "--root", "--svg" })
end)

suite:case("the_manual_page_has_every_command_and_groff_reads_it_without_a_warning", function()
  local f = assert(io.open(src .. "/packaging/dca.1.in"))
  local template = f:read("a")
  f:close()
  local cmds = doc.commands(dca)
  T.ok(#cmds >= 15, "the commands of `dca help`: " .. #cmds)
  local page = doc.man(cmds, template)
  for _, c in ipairs(cmds) do T.contains(page, ".SS \"dca " .. c.name:gsub("%-", "\\-") .. "\"") end
  T.contains(page, "\\-\\-placement")
  T.ok(not page:find("@COMMANDS@", 1, true), "the marker replaced")
  local file = T.tmpname(".1")
  f = assert(io.open(file, "w"))
  f:write(page)
  f:close()
  local out, rc = T.sh("groff -man -Tutf8 -ww -z " .. file)
  T.eq({ rc, out }, { 0, "" }, "groff's warnings")
  out = T.sh("groff -man -Tutf8 -P-cbou " .. file)
  T.contains(out, "dca run")
  T.contains(out, "--placement")
  os.remove(file)
end)

return suite:run(...)
