-- README.md's "Bring your own robot", followed as written: its URDF and its system are taken from the section's
-- code blocks (nothing else), their ports listed, and the system run in the Simbody world, on mock hardware and
-- with a dead drive, and verified.
local T = require "dca.testing"
local suite = T.suite("robot")

local dca, src = T.exe, T.src

-- The section's text, its URDF and its .dca (the first ```xml block, and the first plain block after it).
local function files()
  local readme = T.read(src .. "/README.md")
  local section = readme:match("\n## Bring your own robot\n(.-)\n## ")
  T.ok(section, "README.md has a section \"Bring your own robot\"")
  local urdf = section:match("```xml\n(.-)```")
  local dca_text = section:match("\n%s*```\n(.-)%s*```", section:find("```xml\n.-```") and select(2, section:find("```xml\n.-```")) or 1)
  T.ok(urdf and dca_text, "the section has a URDF and a system")
  local dir = T.tmpdir()
  T.write(dir .. "/pan_tilt.urdf", urdf)
  T.write(dir .. "/look.dca", (dca_text:gsub("\n   ", "\n")))
  return dir, section
end

local function run(dir, args)
  return T.sh("cd " .. dir .. " && timeout 120 " .. dca .. " " .. args)
end

suite:case("its_ports_are_the_ones_the_section_names", function()
  local dir, section = files()
  local out, rc = run(dir, "types --world pan_tilt.urdf")
  T.eq(rc, 0, out)
  for port in section:match("1%. %*%*See its ports%.%*%*(.-)\n2%."):gmatch("`(joint%.[%w_.]+)`") do
    T.contains(out, port)
  end
  T.contains(out, "in     joint.tilt.position_command")
end)

suite:case("the_system_ends_done_in_simbody_and_on_mock_hardware", function()
  local dir = files()
  for _, world in ipairs({ "pan_tilt.urdf", "mock:pan_tilt.urdf" }) do
    local out, rc = run(dir, "run look.dca --sim " .. world .. " --quiet")
    T.eq(rc, 0, world .. ": " .. out)
    T.contains(out, "main.look  done")
  end
end)

suite:case("a_dead_tilt_drive_ends_it_aborted_naming_the_joint", function()
  local dir = files()
  local out, rc = run(dir, "run look.dca --sim 'mock:pan_tilt.urdf?dead=tilt' --quiet")
  T.eq(rc, 1, out)
  T.contains(out, "ABORTED")
  T.contains(out, "tilt")
end)

suite:case("it_verifies", function()
  local dir = files()
  local out, rc = run(dir, "check --verify look.dca --sim pan_tilt.urdf")
  T.eq(rc, 0, out)
end)

return suite:run(...)
