// SPDX-License-Identifier: MIT
// Run control shared by both tops: the load / run / drain / done state
// machine and the cycle counters of each phase (rtl/README.md, "what each
// phase counts"). The sequencer reports each cycle whether it issued a step,
// a restart bubble, or finished; after the finish the pipeline drains for
// LAT cycles (the finish cycle is drain cycle 1) and done rises the cycle
// after the last. n < 2 issues nothing: no drain.
module hbp_run_control #(
    parameter int CAP = 1024,  // boxes the buffer holds
    parameter int NW  = 11,    // box count bits
    parameter int LAT = 6,     // register stages from step to pair line
    parameter bit RESTARTS = 1 // the sequencer has restart bubbles (else cyc_restart is a constant 0)
) (
    input  logic          clk,
    input  logic          rst,         // synchronous, active high (rst || clear)
    input  logic          load_valid,  // one box per cycle, index = n_loaded
    input  logic          start,
    input  logic          seq_step,    // the sequencer issued a step
    input  logic          seq_bubble,  // the sequencer waited (row restart)
    input  logic          seq_finish,  // the sequencer's last cycle
    output logic          in_load,     // still loading: start is accepted
    output logic          loading,     // this cycle writes box n_loaded
    output logic          busy,
    output logic          done,
    output logic          load_error,  // a load past capacity was dropped
    output logic [NW-1:0] n_loaded,
    output logic [31:0]   cyc_load,
    output logic [31:0]   cyc_seq,
    output logic [31:0]   cyc_restart,
    output logic [31:0]   cyc_drain,
    output logic [31:0]   cycles       // cyc_seq + cyc_restart + cyc_drain
);
  typedef enum logic [1:0] {S_LOAD, S_RUN, S_DRAIN, S_DONE} state_t;
  state_t state;
  logic [3:0] drain_left;

  assign in_load = (state == S_LOAD);
  assign loading = (state == S_LOAD) && load_valid && (32'(n_loaded) < 32'(CAP));
  assign busy    = (state == S_RUN) || (state == S_DRAIN);
  assign done    = (state == S_DONE);
  assign cycles  = cyc_seq + cyc_restart + cyc_drain;

  always_ff @(posedge clk) begin
    if (rst) begin
      state       <= S_LOAD;
      n_loaded    <= '0;
      load_error  <= 1'b0;
      cyc_load    <= '0;
      cyc_seq     <= '0;
      cyc_drain   <= '0;
      drain_left  <= '0;
    end else begin
      case (state)
        S_LOAD: begin
          if (loading) begin
            n_loaded <= n_loaded + 1'b1;
            cyc_load <= cyc_load + 1;
          end else if (load_valid) begin
            load_error <= 1'b1;
          end
          if (start) state <= S_RUN;
        end
        S_RUN: begin
          if (seq_step) cyc_seq <= cyc_seq + 1;
          if (seq_finish) begin
            // n < 2: nothing in flight, no drain. Otherwise this is drain
            // cycle 1 of LAT; done rises the cycle after the last one.
            if (cyc_seq == 0 && !seq_step) state <= S_DONE;
            else begin
              cyc_drain  <= cyc_drain + 1;
              state      <= (LAT > 1) ? S_DRAIN : S_DONE;
              drain_left <= 4'(LAT - 2);
            end
          end
        end
        S_DRAIN: begin
          cyc_drain <= cyc_drain + 1;
          if (drain_left == 0) state <= S_DONE;
          else drain_left <= drain_left - 1'b1;
        end
        default: ;
      endcase
    end
  end

  // Restart bubbles are counted in the run state only.
  generate
    if (RESTARTS) begin : g_restart
      always_ff @(posedge clk) begin
        if (rst) cyc_restart <= '0;
        else if (state == S_RUN && seq_bubble) cyc_restart <= cyc_restart + 1;
      end
    end else begin : g_no_restart
      assign cyc_restart = '0;
      logic unused;
      assign unused = seq_bubble;
    end
  endgenerate
endmodule
