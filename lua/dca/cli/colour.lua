-- Colour in the CLI's output, on a terminal only: a run's lines (its states: faults red, done green, restarts
-- yellow, the time stamps dim) and the diagnostics of `dca check` (locations bold, carets green, counts red).
--   colour.on(fd)        --> whether output to fd (1 stdout, 2 stderr) is coloured: a terminal, $NO_COLOR unset or
--                            empty (no-color.org), $TERM not "dumb"; $DCA_COLOR=always|never decides first
--   colour.line(text)    --> a run's line with its state word coloured
--   colour.diag(text)    --> diagnostics with their locations, carets and error count coloured
local M = {}

local RED, GREEN, YELLOW, BOLD, BOLD_RED, DIM, RESET = "\27[31m", "\27[32m", "\27[33m", "\27[1m", "\27[1;31m", "\27[2m",
  "\27[0m"

--- `env` (a getenv) and `isatty` (fd -> bool) default to the process's own.
function M.on(fd, env, isatty)
  env = env or os.getenv
  local forced = env("DCA_COLOR")
  if forced == "always" then return true end
  if forced == "never" then return false end
  local no = env("NO_COLOR")
  if no and no ~= "" then return false end
  if env("TERM") == "dumb" then return false end
  isatty = isatty or require("dca.core").isatty
  return isatty(fd) and true or false
end

local WORD = {
  aborted = BOLD_RED, ABORTED = BOLD_RED, exited = RED, lost = RED, aborting = RED,
  done = GREEN, DONE = GREEN, restarting = YELLOW, restarted = YELLOW,
}

--- "[sim   1.250] main.a: aborted (why)": the stamp dim, the state word in its colour.
function M.line(text)
  local stamp, rest = text:match("^(%[[^%]]*%] )(.*)$")
  stamp, rest = stamp or "", rest or text
  local path, word, tail = rest:match("^(%S+: )(%a+)(.*)$")
  local c = word and WORD[word]
  if c then rest = path .. c .. word .. RESET .. tail end
  return (stamp ~= "" and DIM .. stamp .. RESET or "") .. rest
end

--- A diagnostic of `dca check` ("file:2:37: main.a: unknown process type ...", its source line, a caret under the
--- column, and "file: 1 error"): the location bold, the caret green, the count red (as compilers colour theirs).
function M.diag(text)
  local out = {}
  for line in (text .. "\n"):gmatch("([^\n]*)\n") do
    local loc, rest = line:match("^(%S-:%d+:%d+:)(.*)$")
    if loc then line = BOLD .. loc .. RESET .. rest
    elseif line:match("^%s*%^[%^~]*%s*$") then line = GREEN .. line .. RESET
    else
      local file, count = line:match("^(%S+: )(%d+ errors?)$")
      if file then line = file .. BOLD_RED .. count .. RESET end
    end
    out[#out + 1] = line
  end
  return table.concat(out, "\n")
end

return M
