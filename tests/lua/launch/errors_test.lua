-- Errors surface: a world that fails to start shows its own message in the output of the command that
-- started it. Without this, `dca run --sim door` with a broken robot URDF said only "the world (dca sim
-- --serve) exited with code 1 on host manip"; the XML error with file:line was in a daemon log the run deleted.
local T = require "dca.testing"
local core = require "dca.core"
local suite = T.suite("errors")

local dca, src = T.exe, T.src

suite:case("a_world_with_a_broken_urdf_says_the_xml_error_with_file_and_line", function()
  local dir = T.tmpdir()
  for _, name in ipairs(assert(core.list_dir(src .. "/sim/models"))) do
    if name:find("%.urdf$") then T.write(dir .. "/" .. name, T.read(src .. "/sim/models/" .. name)) end
  end
  local urdf = dir .. "/mobile_manipulator.urdf"
  local text = T.read(urdf)
  local first_link = text:find("<link", text:find("<robot name", 1, true), true)
  local eol = text:find("\n", first_link, true)
  T.write(urdf, text:sub(1, eol) .. '  <link name="broken">\n' .. text:sub(eol + 1))  -- never closed
  local out, rc = T.sh("DCA_MODELS_DIR=" .. dir .. " timeout 60 " .. dca .. " run " .. src
    .. "/scripts/systems/test_three_hosts.dca --sim door")
  core.remove_tree(dir)
  T.eq(rc, 3, "exit code (the start failed)\n" .. out)
  T.contains(out, "the world (dca sim --serve) exited with code 1")
  T.contains(out, "dca sim: " .. urdf .. ":")
  T.contains(out, "not well-formed XML")
end)

return suite:run(...)
