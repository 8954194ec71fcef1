read_liberty docs/results/asic/logs/osu018_wl.lib
read_verilog docs/results/asic/logs/ae_m1.netlist.v
link_design hbp_area_efficient
create_clock -name clk -period 10 [get_ports clk]
set inputs [delete_from_list [all_inputs] [get_ports clk]]
set_input_delay 0 -clock clk $inputs
set_output_delay 0 -clock clk [all_outputs]
set_driving_cell -lib_cell BUFX2 $inputs
set_load 0.02 [all_outputs]
report_checks -path_delay max -digits 3 -fields {fanout cap slew}
report_worst_slack -digits 4
set_power_activity -global -activity 0.396658
set_power_activity -input -activity 0.012020
report_power -digits 6
