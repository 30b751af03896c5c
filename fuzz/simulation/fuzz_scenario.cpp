// Fuzz harness: synthetic drive scenario YAML files.
#include <stdexcept>

#include "fuzz_input.h"
#include "grid_vision_fusion/simulation/synthetic_scenario.h"

GVF_FUZZ_TARGET(scenario)
{
  try
  {
    grid_vision_fusion::parseScenario(gvf_fuzz::text(data, size), "fuzz");
  }
  catch (const std::runtime_error&)
  {
  }
  return 0;
}
