# SPDX-License-Identifier: Apache-2.0
# include()d by the packaging check scripts (cmake -P): installs one install component of a build tree into a
# fresh prefix, as a user or packager would (`cmake --install <build> --prefix <prefix> --component <name>`).
function(hapticopt_install_component binary_dir prefix component config)
  file(REMOVE_RECURSE "${prefix}")
  set(_config_args "")
  if(config)
    set(_config_args --config "${config}")
  endif()
  execute_process(COMMAND "${CMAKE_COMMAND}" --install "${binary_dir}" --prefix "${prefix}" --component ${component}
                          ${_config_args}
                  COMMAND_ECHO STDOUT COMMAND_ERROR_IS_FATAL ANY)
endfunction()
