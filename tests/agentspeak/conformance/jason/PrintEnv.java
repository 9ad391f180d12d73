import jason.asSyntax.Structure;
import jason.environment.Environment;

/** What mrss's ConsoleHost does with an environment action: print it, succeed at once.
 *  On stderr, beside the agent's .print lines, so the two keep their order. */
public class PrintEnv extends Environment {
    @Override
    public boolean executeAction(String agName, Structure action) {
        System.err.println("[" + agName + "] action: " + action);
        return true;
    }
}
