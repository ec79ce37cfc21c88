-- The CLI's reference generated from the commands' own texts (`dca help` and `dca help CMD`, the registry the
-- dispatcher uses), so that it cannot drift from them:
--   doc.commands(exe)          -- { {name=, summary=, usage=, options={"--root", ...}}, ... } in `dca help` order
--   doc.bash(cmds)             -- the bash completion script (`dca completion bash`; installed by the package as
--                              -- /usr/share/bash-completion/completions/dca)
--   doc.man(cmds, template)    -- the manual page dca(1): the template (packaging/dca.1.in) with its @COMMANDS@
--                              -- line replaced by a section per command (summary and usage text)
-- Not a command itself (no summary).
local M = {}

local function capture(cmd)
  local p = assert(io.popen(cmd, "r"))
  local out = p:read("a")
  p:close()
  return out
end

local function quote(s) return "'" .. tostring(s):gsub("'", "'\\''") .. "'" end

--- The options a usage text gives ("--root", "--world-opt", ...), sorted, each once: those of its synopsis (the
--- lines up to the first empty one) and of the lines that describe one ("  --root NAME  ..."), not those it
--- only mentions (`dca sim --worlds` lists them).
function M.options(usage)
  local seen, out, synopsis = { ["--help"] = true }, {}, true
  local function take(text)
    for o in text:gmatch("%f[%w%-]%-%-[%a][%w%-]*") do
      if not seen[o] then seen[o] = true out[#out + 1] = o end
    end
  end
  for line in (tostring(usage) .. "\n"):gmatch("([^\n]*)\n") do
    if line:match("^%s*$") then synopsis = false end
    if synopsis then take((line:gsub("`[^`]*`", "")))
    elseif line:match("^%s+%-%-") then take(line:match("^%s+(%S+)")) end
  end
  table.sort(out)
  return out
end

--- Every command of `exe` with its summary, usage text and options.
function M.commands(exe)
  local list = capture(quote(exe) .. " help 2>&1")
  local cmds, on = {}, false
  for line in list:gmatch("[^\n]*") do
    if line == "commands:" then on = true
    elseif on then
      local name, summary = line:match("^  (%S+)%s+(.*)$")
      if name then cmds[#cmds + 1] = { name = name, summary = summary } end
    end
  end
  for _, c in ipairs(cmds) do
    c.usage = c.name == "help" and "usage: dca help [COMMAND]" or capture(quote(exe) .. " help " .. quote(c.name) .. " 2>&1")
    c.usage = c.usage:gsub("%s+$", "")
    c.options = M.options(c.usage)
  end
  return cmds
end

--- The bash completion script: the commands after `dca`, a command's options after `-`, files otherwise.
function M.bash(cmds)
  local names, cases = { "--help", "--version" }, {}
  for _, c in ipairs(cmds) do
    names[#names + 1] = c.name
    local opts = table.concat(c.options, " ")
    if c.name == "help" then
      local all = {}
      for _, d in ipairs(cmds) do if d.name ~= "help" then all[#all + 1] = d.name end end
      cases[#cases + 1] = string.format("    help) COMPREPLY=($(compgen -W %s -- \"$cur\")); return ;;",
        quote(table.concat(all, " ")))
    else
      cases[#cases + 1] = string.format("    %s) opts=%s ;;", c.name, quote(opts .. (opts ~= "" and " " or "") .. "--help"))
    end
  end
  return table.concat({
    "# bash completion for dca, generated from its commands' usage texts (dca completion bash)",
    "_dca() {",
    "  local cur=\"${COMP_WORDS[COMP_CWORD]}\" opts=''",
    "  if [ \"$COMP_CWORD\" -eq 1 ]; then",
    "    COMPREPLY=($(compgen -W " .. quote(table.concat(names, " ")) .. " -- \"$cur\"))",
    "    return",
    "  fi",
    "  case \"${COMP_WORDS[1]}\" in",
    table.concat(cases, "\n"),
    "  esac",
    "  if [[ \"$cur\" == -* ]]; then COMPREPLY=($(compgen -W \"$opts\" -- \"$cur\")); return; fi",
    "  COMPREPLY=()  # (files: -o default)",
    "}",
    "complete -o default -F _dca dca",
    "",
  }, "\n")
end

-- Text for roff: backslashes and hyphens escaped, a line that would start with a control character guarded.
local function roff(s)
  s = s:gsub("\\", "\\e"):gsub("%-", "\\-")
  return (s:gsub("^([.'])", "\\&%1"):gsub("\n([.'])", "\n\\&%1"))
end

--- The manual page: `template` with its line "@COMMANDS@" replaced by the commands' section.
function M.man(cmds, template)
  local out = { ".SH COMMANDS" }
  for _, c in ipairs(cmds) do
    out[#out + 1] = ".SS \"dca " .. roff(c.name) .. "\""
    out[#out + 1] = roff(c.summary)
    out[#out + 1] = ".PP"
    out[#out + 1] = ".nf"
    out[#out + 1] = roff(c.usage)
    out[#out + 1] = ".fi"
  end
  local section = table.concat(out, "\n")
  local text, n = template:gsub("\n@COMMANDS@\n", function() return "\n" .. section .. "\n" end)
  assert(n == 1, "the template has no line @COMMANDS@")
  return text
end

return M
